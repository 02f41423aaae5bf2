#include "laser_loop_closure/core/slam/session_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include "laser_loop_closure/core/common/file_util.hpp"
#include "laser_loop_closure/core/slam/slam_back_end.hpp"

namespace llc {
namespace {

const char kMagic[] = "LLC-SESSION\n";  // 12 bytes, no terminator written
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
constexpr std::uint64_t kMaxCount = std::uint64_t(1) << 32;  // a count beyond this is corruption

std::uint64_t fnv1a(const char* data, std::size_t size) {
  std::uint64_t hash = 14695981039346656037ull;
  for (std::size_t i = 0; i < size; ++i) hash = (hash ^ std::uint8_t(data[i])) * 1099511628211ull;
  return hash;
}

/// Little-endian on the machines ROS runs on; the magic's version guards the layout.
class Writer {
 public:
  template <class T>
  void raw(T value) {
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void count(std::size_t n) { raw(std::uint64_t(n)); }
  void number(double v) { raw(v); }
  void flag(bool b) { raw(std::uint8_t(b)); }
  void pose(const Pose2& p) { number(p.x), number(p.y), number(p.theta); }
  void matrix(const Eigen::Matrix3d& m) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) number(m(r, c));
  }
  void text(const std::string& s) { count(s.size()), bytes_.append(s); }
  void numbers(const std::vector<double>& v) {
    count(v.size());
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

class Reader {
 public:
  Reader(const std::string& bytes, std::size_t begin, std::size_t end, const std::string& path)
      : bytes_(bytes), at_(begin), end_(end), path_(path) {}
  template <class T>
  T raw() {
    need(sizeof(T));
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::size_t count() {
    const std::uint64_t n = raw<std::uint64_t>();
    if (n > kMaxCount) fail("a count of " + std::to_string(n));
    return std::size_t(n);
  }
  /// A count of items that each take at least min_bytes of what follows: refused when the
  /// rest of the data cannot hold them, before anything is sized by it.
  std::size_t items(std::size_t min_bytes) {
    const std::size_t n = count();
    if (n > (end_ - at_) / min_bytes) fail("a count of " + std::to_string(n) + " that the " + std::to_string(end_ - at_) + " bytes left cannot hold");
    return n;
  }
  double number() { return raw<double>(); }
  bool flag() {
    const std::uint8_t b = raw<std::uint8_t>();
    if (b > 1) fail("a flag of " + std::to_string(b));
    return b == 1;
  }
  Pose2 pose() {
    Pose2 p;
    p.x = number(), p.y = number(), p.theta = number();
    return p;
  }
  Eigen::Matrix3d matrix() {
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = number();
    return m;
  }
  std::string text() {
    const std::size_t n = count();
    need(n);
    std::string s = bytes_.substr(at_, n);
    at_ += n;
    return s;
  }
  std::vector<double> numbers() {
    const std::size_t n = count();
    need(n * sizeof(double));
    std::vector<double> v(n);
    std::memcpy(v.data(), bytes_.data() + at_, n * sizeof(double));
    at_ += n * sizeof(double);
    return v;
  }
  LoopRefusal refusal() {
    const std::uint8_t code = raw<std::uint8_t>();
    if (code >= kLoopRefusalKinds) fail("a refusal code of " + std::to_string(code));
    return LoopRefusal(code);
  }
  bool done() const { return at_ == end_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw SessionError(path_ + ": corrupt session (" + what + " at byte " + std::to_string(at_) + ")");
  }

 private:
  void need(std::size_t n) const {
    if (n > end_ - at_) fail("the data ends early");
  }
  const std::string& bytes_;
  std::size_t at_, end_;
  const std::string& path_;
};

std::string payload(const SlamSession& s) {
  Writer w;
  w.count(s.keyframes.size());
  for (const Keyframe& k : s.keyframes) {
    w.count(k.scan_index), w.number(k.stamp), w.flag(k.has_wheel_odometry), w.pose(k.wheel_odometry);
    w.number(k.scan.stamp), w.flag(k.scan.full_circle), w.numbers(k.scan.ranges), w.numbers(k.scan.bearings);
  }
  for (const std::vector<double>& f : s.features) w.numbers(f);
  for (const Pose2& p : s.poses) w.pose(p);
  w.count(s.constraints.size());
  for (const PoseEdge& e : s.constraints) w.count(e.from), w.count(e.to), w.pose(e.measurement), w.matrix(e.information);
  w.count(s.loops.size());
  for (const LoopRecord& r : s.loops) {
    const LoopClosure& l = r.loop;
    w.count(l.from), w.count(l.to), w.number(l.score), w.pose(l.pose), w.matrix(l.covariance);
    w.number(l.inlier_share), w.flag(l.accepted), w.text(l.reject_reason), w.number(l.seconds);
    w.flag(r.applied), w.number(r.innovation_chi2), w.text(r.reject_reason);
  }
  // Version 2: one flag per loop record, after them all (so a version-1 body is a prefix).
  for (const LoopRecord& r : s.loops) w.flag(r.by_consensus);
  // Version 3: the loop's and the record's refusal codes, per loop record, after them all.
  for (const LoopRecord& r : s.loops) w.raw(std::uint8_t(r.loop.refusal)), w.raw(std::uint8_t(r.refusal));
  // Version 4: each keyframe's robot, a uint32, after everything.
  for (std::size_t k = 0; k < s.keyframes.size(); ++k) w.raw(s.robots.empty() ? std::uint32_t(0) : s.robots[k]);
  return std::move(w.bytes());
}

/// Versions 1 and 2 kept a loop's refusal only as the first words of its reason, as the stages
/// of those versions wrote them: decoded here, once, for such a file (nothing else reads reasons).
LoopRefusal refusalWrittenIn(const std::string& reason) {
  auto starts = [&](const char* prefix) { return reason.rfind(prefix, 0) == 0; };
  if (reason.empty()) return LoopRefusal::kNone;
  if (starts("place gate: ")) return LoopRefusal::kPlaceGate;
  if (starts("crf: ")) return LoopRefusal::kCrfMatch;
  if (starts("icp: ")) return LoopRefusal::kIcp;
  if (starts("validation: ")) return LoopRefusal::kValidation;
  if (starts("context: ")) return LoopRefusal::kContext;
  if (starts("backend: innovation chi2 ")) return LoopRefusal::kBackEndGate;
  if (starts("backend: the system could not be solved")) return LoopRefusal::kBackEndUnsolvable;
  if (starts("backend: ")) return LoopRefusal::kBackEndMalformed;
  return LoopRefusal::kOther;
}

// The fewest bytes each item of the payload takes (fixed fields, empty vectors and texts).
constexpr std::size_t kKeyframeBytes = 8 + 8 + 1 + 24 + 8 + 1 + 8 + 8 + 8 + 24;  // its features and pose follow
constexpr std::size_t kConstraintBytes = 8 + 8 + 24 + 72;
constexpr std::size_t kLoopBytes = 8 + 8 + 8 + 24 + 72 + 8 + 1 + 8 + 8 + 1 + 8 + 8;

SlamSession parse(Reader& r, std::uint32_t version) {
  SlamSession s;
  s.keyframes.resize(r.items(kKeyframeBytes));
  for (Keyframe& k : s.keyframes) {
    k.scan_index = r.count(), k.stamp = r.number(), k.has_wheel_odometry = r.flag(), k.wheel_odometry = r.pose();
    k.scan.stamp = r.number(), k.scan.full_circle = r.flag(), k.scan.ranges = r.numbers(), k.scan.bearings = r.numbers();
  }
  s.features.resize(s.keyframes.size());
  for (std::vector<double>& f : s.features) f = r.numbers();
  s.poses.resize(s.keyframes.size());
  for (Pose2& p : s.poses) p = r.pose();
  s.constraints.resize(r.items(kConstraintBytes));
  for (PoseEdge& e : s.constraints) e.from = r.count(), e.to = r.count(), e.measurement = r.pose(), e.information = r.matrix();
  s.loops.resize(r.items(kLoopBytes));
  for (LoopRecord& rec : s.loops) {
    LoopClosure& l = rec.loop;
    l.from = r.count(), l.to = r.count(), l.score = r.number(), l.pose = r.pose(), l.covariance = r.matrix();
    l.inlier_share = r.number(), l.accepted = r.flag(), l.reject_reason = r.text(), l.seconds = r.number();
    rec.applied = r.flag(), rec.innovation_chi2 = r.number(), rec.reject_reason = r.text();
  }
  if (version >= 2)
    for (LoopRecord& rec : s.loops) rec.by_consensus = r.flag();
  if (version >= 3) {
    for (LoopRecord& rec : s.loops) rec.loop.refusal = r.refusal(), rec.refusal = r.refusal();
  } else {
    for (LoopRecord& rec : s.loops) rec.loop.refusal = refusalWrittenIn(rec.loop.reject_reason), rec.refusal = refusalWrittenIn(rec.reject_reason);
  }
  if (version >= 4) {
    s.robots.resize(s.keyframes.size());
    for (std::uint32_t& robot : s.robots) robot = r.raw<std::uint32_t>();
  }
  if (!r.done()) r.fail("bytes left over");
  return s;
}

}  // namespace

std::string SlamSession::validate() const {
  const std::size_t n = keyframes.size();
  if (features.size() != n || poses.size() != n)
    return std::to_string(n) + " keyframes but " + std::to_string(features.size()) + " feature vectors and " +
           std::to_string(poses.size()) + " poses";
  for (std::size_t k = 0; k < n; ++k) {
    const Keyframe& key = keyframes[k];
    if (key.scan.ranges.size() != key.scan.bearings.size()) return "keyframe " + std::to_string(k) + ": ranges and bearings differ in count";
    if (!std::isfinite(key.stamp) || !isFinite(poses[k]) || (key.has_wheel_odometry && !isFinite(key.wheel_odometry)))
      return "keyframe " + std::to_string(k) + ": a stamp or pose is not finite";
    if (features[k].size() != features[0].size()) return "keyframe " + std::to_string(k) + ": feature vectors differ in length";
  }
  std::size_t odometry = 0;
  for (std::size_t i = 0; i < constraints.size(); ++i) {
    const PoseEdge& e = constraints[i];
    const std::string which = "constraint " + std::to_string(i);
    if (e.from >= n || e.to >= n || e.from == e.to) return which + " joins unknown poses";
    if (e.to == odometry + 1 && e.from < e.to) ++odometry;  // augmentations arrive in order
    else if (e.to > odometry) return which + " reaches pose " + std::to_string(e.to) + " before it exists";
    if (!isFinite(e.measurement) || !e.information.allFinite()) return which + " is not finite";
  }
  if (n > 0 && odometry != n - 1) return "only " + std::to_string(odometry + 1) + " of " + std::to_string(n) + " poses are linked";
  if (!robots.empty() && robots.size() != n)
    return std::to_string(n) + " keyframes but " + std::to_string(robots.size()) + " robots named";
  for (std::size_t i = 0; i < loops.size(); ++i) {
    if (loops[i].loop.from >= n || loops[i].loop.to >= n) return "loop " + std::to_string(i) + " names an unknown keyframe";
    if (loops[i].by_consensus && !loops[i].applied)
      return "loop " + std::to_string(i) + " is marked applied by consensus but not applied";
    if (loops[i].applied && loops[i].refusal != LoopRefusal::kNone)
      return "loop " + std::to_string(i) + " is applied but marked refused";
  }
  return "";
}

void saveSession(const SlamSession& session, const std::string& path) {
  const std::string invalid = session.validate();
  if (!invalid.empty()) throw SessionError(path + ": not saved, the session is inconsistent: " + invalid);
  const std::string body = payload(session);
  Writer file;
  file.bytes().append(kMagic, kMagicSize);
  file.raw(kSessionVersion);
  file.count(body.size());
  file.bytes().append(body);
  file.raw(fnv1a(body.data(), body.size()));
  try {
    writeFileAtomically(path, file.bytes());
  } catch (const std::runtime_error& e) {
    throw SessionError(e.what());
  }
}

SlamSession loadSession(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SessionError(path + ": no such file or not readable");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < kMagicSize || bytes.compare(0, kMagicSize, kMagic) != 0)
    throw SessionError(path + ": not a laser_loop_closure session file");
  const std::size_t begin = kMagicSize + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  if (bytes.size() < begin + sizeof(std::uint64_t))
    throw SessionError(path + ": truncated session file (" + std::to_string(bytes.size()) + " bytes)");
  Reader header(bytes, kMagicSize, bytes.size(), path);
  const std::uint32_t version = header.raw<std::uint32_t>();
  if (version < kOldestSessionVersion || version > kSessionVersion)
    throw SessionError(path + ": session version " + std::to_string(version) + ", this build reads versions " +
                       std::to_string(kOldestSessionVersion) + " to " + std::to_string(kSessionVersion));
  const std::uint64_t size = header.raw<std::uint64_t>();
  if (size > bytes.size() - begin || bytes.size() - begin - size != sizeof(std::uint64_t))
    throw SessionError(path + ": truncated session file (" + std::to_string(bytes.size()) + " bytes, the header announces " +
                       std::to_string(begin + size + sizeof(std::uint64_t)) + ")");
  Reader trailer(bytes, begin + size, bytes.size(), path);
  if (trailer.raw<std::uint64_t>() != fnv1a(bytes.data() + begin, size))
    throw SessionError(path + ": corrupt session file (checksum mismatch)");
  Reader body(bytes, begin, begin + size, path);
  SlamSession session = parse(body, version);
  const std::string invalid = session.validate();
  if (!invalid.empty()) throw SessionError(path + ": inconsistent session: " + invalid);
  return session;
}

KeyframeRobots KeyframeRobots::afterRestore(const SlamSession& session, bool continue_odometry) {
  KeyframeRobots robots;
  robots.restored = session.robots.empty() ? std::vector<std::uint32_t>(session.keyframes.size(), 0) : session.robots;
  if (robots.restored.empty()) return robots;
  robots.current = continue_odometry ? robots.restored.back()
                                     : *std::max_element(robots.restored.begin(), robots.restored.end()) + 1;
  return robots;
}

std::vector<std::uint32_t> KeyframeRobots::of(std::size_t keyframes) const {
  std::vector<std::uint32_t> out(restored.begin(), restored.begin() + long(std::min(keyframes, restored.size())));
  out.resize(keyframes, current);
  return out;
}

SlamSession sessionOf(const SlamBackEnd& back, const std::vector<std::vector<double>>& features,
                      const KeyframeRobots* robots) {
  SlamSession session;
  if (robots) session.robots = robots->of(back.keyframes().size());
  session.keyframes = back.keyframes();
  session.features = features;
  session.poses = back.poses();
  if (const Esdf* esdf = back.esdf()) session.constraints = esdf->constraints();
  session.loops = back.loops();
  return session;
}

}  // namespace llc
