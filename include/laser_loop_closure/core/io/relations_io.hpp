// Reference relations of the Kümmerle et al. 2009 benchmark (.relations files).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "laser_loop_closure/core/geometry/relation_error.hpp"

namespace llc {

class RelationsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads one relation per line: `t1 t2 x y z roll pitch yaw` (s, m, rad; the motion from the
/// scan stamped t1 to the one stamped t2 in the frame of the first). Blank lines and lines
/// starting with '#' are skipped. Throws RelationsError naming the file and line on a missing
/// file, a line with another count of values, a value that is not a finite number, or a file
/// with no relation.
std::vector<Relation> loadRelations(const std::string& path);

}  // namespace llc
