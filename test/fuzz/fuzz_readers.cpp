// Deterministic mutation fuzzing of every file reader a user can point the tools at: a CARMEN
// log, a bag, a g2o graph, a classifier model, a session, CRF weights, a pipeline config, a
// relations file and a pair file. Each reader gets seed files made here (a short simulated
// drive, its map and model), then mutated copies: bits flipped, bytes overwritten with random
// or boundary values (0, 2^31, 2^32-1, 4.3e8 ...), bytes inserted, deleted or duplicated, the
// file cut short, and in text files a number replaced by nan, inf, -1, 1e308, 4294967295 or
// junk. A case passes when the reader returns or throws its own error naming the file. It
// fails on any other exception (std::bad_alloc under `ulimit -v`: an allocation beyond the
// bound), and a crash names its case before the process dies. scripts/test runs it.
//   llc_fuzz_readers [--cases-per-reader N] [--seed S] [--dir DIR] [--only NAME]
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <random>
#include <string>
#include <vector>

#include "laser_loop_closure/core/alignment/crf_training.hpp"
#include "laser_loop_closure/core/classifier/classifier_model.hpp"
#include "laser_loop_closure/core/classifier/pair_labeling.hpp"
#include "laser_loop_closure/core/io/carmen_reader.hpp"
#include "laser_loop_closure/core/io/g2o_io.hpp"
#include "laser_loop_closure/core/io/relations_io.hpp"
#include "laser_loop_closure/core/io/scan_sequence.hpp"
#include "laser_loop_closure/core/sim/carmen_writer.hpp"
#include "laser_loop_closure/core/sim/sim_drive.hpp"
#include "laser_loop_closure/core/sim/sim_world.hpp"
#include "laser_loop_closure/core/slam/session_io.hpp"
#include "laser_loop_closure/core/slam/slam_parameters.hpp"
#include "laser_loop_closure/core/slam/slam_pipeline.hpp"
#include "laser_loop_closure/ros/io/bag_io.hpp"

namespace {

// The case being read, for the crash handler (async-signal-safe: a fixed buffer and write(2)).
char g_current[512] = "none yet";

void onCrash(int signal) {
  const char head[] = "\nfuzz_readers: CRASH (signal) in case ";
  ssize_t ignored = write(STDERR_FILENO, head, sizeof head - 1);
  ignored = write(STDERR_FILENO, g_current, strnlen(g_current, sizeof g_current));
  ignored = write(STDERR_FILENO, "\n", 1);
  (void)ignored;
  ::signal(signal, SIG_DFL);
  raise(signal);
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

/// One reader: its seed file, whether it is text, and the call that reads a file as it would.
struct Reader {
  std::string name;
  std::string seed;  ///< path
  bool text = false;
  std::function<void(const std::string&)> read;
  /// Made consistent again after a mutation (a crafted file, not a damaged one): e.g. a
  /// session's body length and checksum rewritten, so the mutation reaches the parser.
  std::function<void(std::string&)> reseal;
};

std::uint64_t fnv1a(const char* data, std::size_t size) {
  std::uint64_t hash = 14695981039346656037ull;
  for (std::size_t i = 0; i < size; ++i) hash = (hash ^ std::uint8_t(data[i])) * 1099511628211ull;
  return hash;
}

/// A session file's header (magic, version, body length) and trailing checksum made to fit its
/// body again (docs/file_formats.md's layout).
void resealSession(std::string& bytes) {
  constexpr std::size_t kHead = 12 + 4 + 8, kTail = 8;
  if (bytes.size() < kHead + kTail) return;
  const std::uint64_t length = bytes.size() - kHead - kTail;
  std::memcpy(&bytes[12 + 4], &length, 8);
  const std::uint64_t checksum = fnv1a(bytes.data() + kHead, length);
  std::memcpy(&bytes[bytes.size() - kTail], &checksum, 8);
}

/// A mutation of `bytes`, chosen and placed by `random`.
std::string mutate(std::string bytes, bool text, std::mt19937_64& random) {
  auto pick = [&](std::size_t n) { return n == 0 ? std::size_t(0) : std::size_t(random() % n); };
  const std::size_t kinds = text ? 9 : 7;
  switch (pick(kinds)) {
    case 0:  // flip 1..8 bits
      for (std::size_t i = 0, n = 1 + pick(8); i < n && !bytes.empty(); ++i) bytes[pick(bytes.size())] ^= char(1 << pick(8));
      break;
    case 1:  // overwrite 1..4 bytes
      for (std::size_t i = 0, n = 1 + pick(4); i < n && !bytes.empty(); ++i) bytes[pick(bytes.size())] = char(random());
      break;
    case 2: {  // a boundary uint32 where a length may be
      static const std::uint32_t values[] = {0u, 1u, 0x7fffffffu, 0x80000000u, 0xffffffffu, 430000000u, 65536u};
      const std::uint32_t v = values[pick(std::size(values))];
      if (bytes.size() >= 4) std::memcpy(&bytes[pick(bytes.size() - 3)], &v, 4);
      break;
    }
    case 3: {  // a boundary uint64 (session counts)
      static const std::uint64_t values[] = {0ull, 1ull << 32, 30000000ull, ~0ull, 1ull << 62};
      const std::uint64_t v = values[pick(std::size(values))];
      if (bytes.size() >= 8) std::memcpy(&bytes[pick(bytes.size() - 7)], &v, 8);
      break;
    }
    case 4: {  // insert 1..16 random bytes
      std::string extra(1 + pick(16), '\0');
      for (char& c : extra) c = char(random());
      bytes.insert(pick(bytes.size() + 1), extra);
      break;
    }
    case 5:  // delete 1..16 bytes
      if (!bytes.empty()) {
        const std::size_t at = pick(bytes.size());
        bytes.erase(at, 1 + pick(16));
      }
      break;
    case 6:  // cut short
      bytes.resize(pick(bytes.size() + 1));
      break;
    case 7: {  // a token of a text file replaced
      static const char* values[] = {"nan", "inf", "-inf", "-1", "1e308", "4294967295", "18446744073709551616", "15xyz", "", "0x10", "1e-320", "[", "{a: 1}"};
      std::size_t at = pick(bytes.size() + 1);
      while (at < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[at])) == 0) ++at;  // the next gap
      while (at < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[at])) != 0) ++at;  // the token after it
      std::size_t end = at;
      while (end < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[end])) == 0 && bytes[end] != ',') ++end;
      bytes.replace(at, end - at, values[pick(std::size(values))]);
      break;
    }
    case 8: {  // a line written twice
      const std::size_t at = bytes.rfind('\n', pick(bytes.size() + 1));
      const std::size_t begin = at == std::string::npos ? 0 : at + 1;
      const std::size_t end = bytes.find('\n', begin);
      const std::string line = bytes.substr(begin, end == std::string::npos ? std::string::npos : end - begin + 1);
      bytes.insert(begin, line);
      break;
    }
  }
  return bytes;
}

/// The seed files of every reader, made from a short simulated drive.
std::vector<Reader> makeSeeds(const std::string& dir, const std::string& source_dir) {
  llc::SimDriveOptions options;
  options.seed = 5;
  options.length_m = 40.0;
  const llc::SimWorld world(llc::simWorldOptions(options));
  const llc::SimDrive drive = llc::simulateDrive(world, options);
  std::vector<Reader> readers;
  const std::string log = dir + "/seed.log", bag = dir + "/seed.bag", model = dir + "/seed_model.yaml";
  llc::writeCarmenLog(drive, log);
  llc_ros::writeSimBag(drive, bag);
  llc::saveClassifierModel(llc::loadClassifierModel(source_dir + "/config/classifier.yaml"), model);
  // A session and its graph from mapping the drive.
  llc::SlamPipeline slam(llc::loadClassifierModel(model));
  const llc::ScanSequence sequence = llc::loadScanSequence(log);
  for (std::size_t i = 0; i < sequence.scans.size(); ++i) (void)slam.addScan(sequence.scans[i].scan, i, &sequence.scans[i].odometry);
  const std::string session = dir + "/seed.llcsession", g2o = dir + "/seed.g2o";
  llc::saveSession(slam.session(), session);
  llc::PoseGraph2 graph;
  graph.poses = slam.poses();
  graph.edges = slam.session().constraints;
  graph.had_vertices = true;
  llc::writeG2o(graph, g2o);
  const std::string crf = dir + "/seed_crf.yaml", relations = dir + "/seed.relations", pairs = dir + "/seed_pairs.csv";
  llc::saveCrfWeights(llc::CrfWeights{}, {{"data", "fuzz seed"}}, crf);
  {
    std::ofstream out(relations);
    for (std::size_t i = 1; i < 40 && i < sequence.scans.size(); ++i)
      out << sequence.scans[i - 1].scan.stamp << " " << sequence.scans[i].scan.stamp << " 0.1 0.0 0 0 0 0.01\n";
  }
  llc::writePairs(pairs, {{0, 5, 1}, {1, 9, 0}, {2, 30, 0}});
  const std::size_t scans = sequence.scans.size();
  readers.push_back({"carmen_log", log, true, [](const std::string& p) { (void)llc::loadScanSequence(p); }});
  readers.push_back({"bag", bag, false, [](const std::string& p) { (void)llc_ros::readBagSequence(p); }});
  readers.push_back({"g2o", g2o, true, [](const std::string& p) { (void)llc::readG2o(p); }});
  readers.push_back({"model", model, true, [](const std::string& p) { (void)llc::loadClassifierModel(p); }});
  // A session that loads is restored as --load-session does: restore() refuses with a reason, never a throw.
  const auto restoring_model = std::make_shared<llc::ClassifierModel>(llc::loadClassifierModel(model));
  readers.push_back({"session", session, false,
                     [restoring_model](const std::string& p) {
                       const llc::SlamSession loaded = llc::loadSession(p);
                       llc::SlamPipeline slam(*restoring_model);
                       std::string why;
                       try {
                         why = slam.restore(loaded, false);
                       } catch (const std::exception& e) {
                         throw std::logic_error(std::string("restore threw instead of refusing: ") + e.what());
                       }
                       if (!why.empty()) throw std::runtime_error(p + ": not restored: " + why);
                     },
                     resealSession});
  readers.push_back({"crf_weights", crf, true, [](const std::string& p) { (void)llc::loadCrfWeights(p); }});
  readers.push_back({"slam_config", source_dir + "/config/slam.yaml", true, [](const std::string& p) {
                       llc::SystemOptions options;
                       llc::loadSystemOptionsYaml(p, &options);
                     }});
  readers.push_back({"relations", relations, true, [](const std::string& p) { (void)llc::loadRelations(p); }});
  readers.push_back({"pairs", pairs, true, [scans](const std::string& p) { (void)llc::readPairs(p, scans); }});
  return readers;
}

long peakKilobytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t per_reader = 250;
  std::uint64_t seed = 1;
  std::string dir = "/tmp/llc_fuzz_readers", only;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--cases-per-reader") per_reader = std::stoul(value);
    else if (flag == "--seed") seed = std::stoull(value);
    else if (flag == "--dir") dir = value;
    else if (flag == "--only") only = value;
    else {
      std::cerr << "usage: llc_fuzz_readers [--cases-per-reader N] [--seed S] [--dir DIR] [--only NAME]\n";
      return 2;
    }
  }
  for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(s, onCrash);
  if (std::system(("mkdir -p '" + dir + "'").c_str()) != 0) return 2;
  std::vector<Reader> readers;
  try {
    readers = makeSeeds(dir, LLC_SOURCE_DIR);
  } catch (const std::exception& e) {
    std::cerr << "fuzz_readers: the seed files could not be made: " << e.what() << "\n";
    return 2;
  }
  const long seeds_peak = peakKilobytes();
  std::size_t total = 0, failures = 0;
  double slowest = 0.0;
  std::string slowest_case;
  for (const Reader& reader : readers) {
    if (!only.empty() && reader.name != only) continue;
    const std::string original = readBytes(reader.seed);
    const std::string path = dir + "/case_" + reader.name + (reader.seed.size() > 4 ? reader.seed.substr(reader.seed.rfind('.')) : "");
    std::size_t accepted = 0, refused = 0, failed = 0;
    try {  // the seed itself must read
      reader.read(reader.seed);
    } catch (const std::exception& e) {
      std::cout << reader.name << ": FAIL: the unmutated seed is refused: " << e.what() << "\n";
      ++failures;
      continue;
    }
    for (std::size_t k = 0; k < per_reader; ++k) {
      std::mt19937_64 random(seed * 1000003ull + std::hash<std::string>{}(reader.name) + k);
      std::string mutated = mutate(original, reader.text, random);
      if (reader.reseal && k % 2 == 1) reader.reseal(mutated);  // every other case crafted, not damaged
      writeBytes(path, mutated);
      std::snprintf(g_current, sizeof g_current, "%s #%zu (--seed %llu; the file: %s)", reader.name.c_str(), k,
                    static_cast<unsigned long long>(seed), path.c_str());
      const auto start = std::chrono::steady_clock::now();
      std::string problem;
      try {
        reader.read(path);
        ++accepted;
      } catch (const std::bad_alloc&) {
        problem = "std::bad_alloc: an allocation beyond the memory bound";
      } catch (const std::exception& e) {
        // A refusal names the file; anything else (or no name) is not the reader's own error.
        if (std::string(e.what()).find(path) != std::string::npos) ++refused;
        else problem = std::string("an error that does not name the file: ") + e.what();
      } catch (...) {
        problem = "a thrown non-exception";
      }
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (seconds > slowest) slowest = seconds, slowest_case = g_current;
      if (!problem.empty()) {
        ++failed;
        if (failed <= 5) std::cout << reader.name << ": FAIL case #" << k << ": " << problem << "\n";
        writeBytes(dir + "/failed_" + reader.name + "_" + std::to_string(k), readBytes(path));
      }
    }
    std::cout << reader.name << ": " << per_reader << " cases, " << refused << " refused naming the file, " << accepted
              << " read (the mutation left a valid file), " << failed << " failed\n";
    total += per_reader;
    failures += failed;
  }
  std::cout << "fuzz_readers: " << total << " cases, " << failures << " failed; slowest case " << slowest << " s (" << slowest_case
            << "); peak memory " << peakKilobytes() / 1024 << " MB (" << seeds_peak / 1024 << " MB after making the seeds)\n";
  return failures == 0 ? 0 : 1;
}
