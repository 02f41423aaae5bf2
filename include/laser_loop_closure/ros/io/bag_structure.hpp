// A bag's record structure checked before rosbag opens it. rosbag sizes its buffers from the
// lengths a record claims (header, data, a chunk's uncompressed size) before it reads them: one
// damaged length makes it reserve gigabytes, and where memory is bounded (ulimit -v) its
// failed allocation ends the process on an assertion. Walking the records first, each length
// against the bytes the file has left, turns that into a refusal that names the byte.
#pragma once

#include <string>

namespace llc_ros {

/// Empty when every record of the bag at `path` (format 2.0) fits the file: each header and
/// data length within the bytes left, each header field within its header, the index position
/// within the file, an uncompressed chunk's records within the chunk and its size equal to its
/// data, a compressed chunk's size at most 1 GiB and 1000 times its data, index and chunk-info
/// records' counts within the bytes left (rosbag reads that many entries). Walked as rosbag
/// reads: the header, the index section, each chunk it names and the index records after it.
/// Otherwise why not, with the byte offset.
std::string bagStructureProblem(const std::string& path);

}  // namespace llc_ros
