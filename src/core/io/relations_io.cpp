#include "laser_loop_closure/core/io/relations_io.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace llc {

std::vector<Relation> loadRelations(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw RelationsError(path + ": cannot be read (" + std::strerror(errno) + ")");
  std::vector<Relation> relations;
  std::string line;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> values;
    for (std::string field; fields >> field;) {
      char* end = nullptr;
      const double value = std::strtod(field.c_str(), &end);
      if (*end != '\0' || !std::isfinite(value))
        throw RelationsError(path + ":" + std::to_string(number) + ": '" + field + "' is not a finite number");
      values.push_back(value);
    }
    if (values.size() != 8)
      throw RelationsError(path + ":" + std::to_string(number) + ": " + std::to_string(values.size()) +
                           " values, not the 8 of 't1 t2 x y z roll pitch yaw'");
    relations.push_back({values[0], values[1], {values[2], values[3], values[7]}});
  }
  if (in.bad()) throw RelationsError(path + ": read failed");
  if (relations.empty()) throw RelationsError(path + ": no relation in it");
  return relations;
}

}  // namespace llc
