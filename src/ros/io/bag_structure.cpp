#include "laser_loop_closure/ros/io/bag_structure.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <utility>
#include <vector>

namespace llc_ros {
namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
constexpr std::uint8_t kOpMessage = 0x02, kOpBagHeader = 0x03, kOpIndex = 0x04, kOpChunk = 0x05, kOpChunkInfo = 0x06,
                       kOpConnection = 0x07;
constexpr std::uint64_t kMaxChunk = std::uint64_t(1) << 30;

struct Problem {
  std::string why;
};

/// A record's header fields by name (the values as bytes).
using Fields = std::map<std::string, std::string>;

class BagWalk {
 public:
  explicit BagWalk(const std::string& path) : in_(path, std::ios::binary | std::ios::ate) {
    if (!in_) throw Problem{"cannot be read"};
    size_ = std::uint64_t(in_.tellg());
  }

  /// As rosbag reads a bag: the bag header, the index section it points to (connections and
  /// chunk infos), then each chunk those name and the index records after it.
  void walk() {
    char magic[kMagicSize];
    if (size_ < kMagicSize || !read(0, magic, kMagicSize) || std::memcmp(magic, kMagic, kMagicSize) != 0)
      throw Problem{"not a version 2.0 bag"};
    Record header = record(kMagicSize, size_);
    if (header.op != kOpBagHeader) fail(kMagicSize, "no bag header record first");
    const std::uint64_t index_pos = number<std::uint64_t>(header.fields, "index_pos", kMagicSize);
    if (index_pos == 0) return;  // unindexed: rosbag refuses it itself, reading nothing
    if (index_pos < header.next || index_pos > size_) fail(kMagicSize, "an index position beyond the file");
    std::vector<std::pair<std::uint64_t, std::uint32_t>> chunks;  // (position, connections)
    for (std::uint64_t at = index_pos; at < size_;) {
      const Record r = record(at, size_);
      if (r.op == kOpChunkInfo) {
        const std::uint32_t connections = number<std::uint32_t>(r.fields, "count", at);
        if (std::uint64_t(connections) * 8 > r.data_size) fail(at, "a chunk-info record whose count its " + std::to_string(r.data_size) + " bytes cannot hold");
        const std::uint64_t chunk_pos = number<std::uint64_t>(r.fields, "chunk_pos", at);
        if (chunk_pos >= index_pos) fail(at, "a chunk position beyond the chunks");
        chunks.emplace_back(chunk_pos, connections);
      } else if (r.op != kOpConnection) {
        fail(at, "a record of op " + std::to_string(r.op) + " in the index section");
      }
      at = r.next;
    }
    for (const auto& [chunk_pos, connections] : chunks) {
      const Record chunk = record(chunk_pos, index_pos);
      if (chunk.op != kOpChunk) fail(chunk_pos, "a chunk-info record that points at no chunk");
      std::uint64_t at = chunk.next;
      for (std::uint32_t i = 0; i < connections; ++i) {
        const Record index = record(at, index_pos);
        if (index.op != kOpIndex) fail(at, "a chunk not followed by its index records");
        checkEntries(index, chunk);
        at = index.next;
      }
    }
  }

 private:
  struct Record {
    std::uint8_t op = 0;
    Fields fields;
    std::uint32_t data_size = 0;
    std::uint64_t next = 0;  ///< where the record after it starts
    std::uint64_t data_at = 0;
    /// An uncompressed chunk's message records, by offset in its data (what index entries name).
    std::vector<std::uint64_t> messages;
    std::uint32_t uncompressed_size = 0;  ///< a chunk's
    bool compressed = false;
  };

  /// The record at `at`, within [at, end): its lengths within the bytes left, its header fields
  /// within the header; an uncompressed chunk's records within it, a compressed one's size bounded.
  Record record(std::uint64_t at, std::uint64_t end, bool in_chunk = false) {
    const std::uint64_t start = at;
    Record r;
    const std::uint32_t header_size = length(at, end, "a record's header length");
    at += 4;
    std::string header(header_size, '\0');
    read(at, header.data(), header_size);
    r.fields = parseFields(header, at);
    at += header_size;
    const auto op = r.fields.find("op");
    if (op == r.fields.end() || op->second.size() != 1) fail(start, "a record without its op field");
    r.op = std::uint8_t(op->second[0]);
    if (r.op == kOpIndex) {
      // rosbag reads an index record's count entries of 12 bytes and ignores its data length
      // (some writers got it wrong: laser_scan_matcher's demo bag says 20 bytes per entry).
      if (at + 4 > end) fail(at, "the file ends inside an index record");
      const std::uint64_t entries = std::uint64_t(number<std::uint32_t>(r.fields, "count", start)) * 12;
      if (number<std::uint32_t>(r.fields, "ver", start) != 1) fail(start, "an index record of another version than 1");
      if (entries > end - at - 4) fail(start, "an index record whose count the " + std::to_string(end - at - 4) + " bytes left cannot hold");
      r.data_size = std::uint32_t(entries);
      r.data_at = at + 4;
      r.next = at + 4 + entries;
      return r;
    }
    r.data_size = length(at, end, "a record's data length");
    at += 4;
    const std::uint64_t data_at = at;
    r.data_at = data_at;
    r.next = at + r.data_size;
    if (in_chunk && r.op != kOpMessage && r.op != kOpConnection) fail(start, "a record of op " + std::to_string(r.op) + " inside a chunk");
    if (r.op == kOpChunk) {
      const std::uint32_t size = number<std::uint32_t>(r.fields, "size", start);
      const auto compression = r.fields.find("compression");
      if (compression == r.fields.end()) fail(start, "a chunk without its compression field");
      r.uncompressed_size = size;
      r.compressed = compression->second != "none";
      if (compression->second == "none") {
        if (size != r.data_size) fail(start, "an uncompressed chunk of " + std::to_string(r.data_size) + " bytes that claims " + std::to_string(size));
        for (std::uint64_t inner = data_at; inner < r.next;) {
          const Record message = record(inner, r.next, true);
          if (message.op == kOpMessage) r.messages.push_back(inner - data_at);
          inner = message.next;
        }
      } else if (size > kMaxChunk || std::uint64_t(size) > 1000 * std::uint64_t(r.data_size)) {
        fail(start, "a compressed chunk of " + std::to_string(r.data_size) + " bytes that claims " + std::to_string(size) + " uncompressed");
      }
    }
    return r;
  }

  /// rosbag reads each message at the offset an index entry names in its chunk's data: an
  /// uncompressed chunk's entries must name one of its message records, a compressed one's lie within its size.
  void checkEntries(const Record& index, const Record& chunk) {
    std::string entries(index.data_size, '\0');
    if (!read(index.data_at, entries.data(), entries.size())) fail(index.data_at, "the file ends inside an index record");
    for (std::size_t i = 0; i + 12 <= entries.size(); i += 12) {
      std::uint32_t offset = 0;
      std::memcpy(&offset, entries.data() + i + 8, 4);  // after the entry's time (sec, nsec)
      const bool found = chunk.compressed ? offset < chunk.uncompressed_size
                                          : std::binary_search(chunk.messages.begin(), chunk.messages.end(), std::uint64_t(offset));
      if (!found) fail(index.data_at + i, "an index entry that names no message of its chunk (offset " + std::to_string(offset) + ")");
    }
  }

  /// A uint32 length at `at`, and the bytes it claims after it, within `end`.
  std::uint32_t length(std::uint64_t at, std::uint64_t end, const char* what) {
    std::uint32_t n = 0;
    if (at + 4 > end || !read(at, reinterpret_cast<char*>(&n), 4)) fail(at, std::string("the file ends inside ") + what);
    if (n > end - at - 4) fail(at, std::string(what) + " of " + std::to_string(n) + " that the " + std::to_string(end - at - 4) + " bytes left cannot hold");
    return n;
  }

  Fields parseFields(const std::string& header, std::uint64_t at) {
    Fields fields;
    std::size_t i = 0;
    while (i < header.size()) {
      std::uint32_t n = 0;
      if (header.size() - i < 4) fail(at + i, "a header field length cut short");
      std::memcpy(&n, header.data() + i, 4);
      i += 4;
      if (n > header.size() - i) fail(at + i - 4, "a header field of " + std::to_string(n) + " bytes in a header of " + std::to_string(header.size()));
      const std::string field = header.substr(i, n);
      const std::size_t equals = field.find('=');
      if (equals == std::string::npos) fail(at + i, "a header field without '='");
      fields[field.substr(0, equals)] = field.substr(equals + 1);
      i += n;
    }
    return fields;
  }

  template <class T>
  T number(const Fields& fields, const std::string& name, std::uint64_t at) {
    const auto found = fields.find(name);
    if (found == fields.end() || found->second.size() != sizeof(T)) fail(at, "a record without a " + std::to_string(sizeof(T)) + "-byte " + name);
    T value;
    std::memcpy(&value, found->second.data(), sizeof(T));
    return value;
  }

  bool read(std::uint64_t at, char* out, std::size_t n) {
    in_.clear();
    in_.seekg(std::streamoff(at));
    return bool(in_.read(out, std::streamsize(n)));
  }

  [[noreturn]] void fail(std::uint64_t at, const std::string& what) { throw Problem{what + " at byte " + std::to_string(at)}; }

  std::ifstream in_;
  std::uint64_t size_ = 0;
};

}  // namespace

std::string bagStructureProblem(const std::string& path) {
  try {
    BagWalk(path).walk();
  } catch (const Problem& problem) {
    return problem.why;
  }
  return "";
}

}  // namespace llc_ros
