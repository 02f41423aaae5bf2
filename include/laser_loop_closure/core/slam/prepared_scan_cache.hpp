// The keyframes' scans prepared for alignment, held within a bound. A prepared scan (points,
// normals, k-d trees, the CRF and global-search descriptors, free space: ScanAligner::prepare)
// is most of a keyframe's memory, about 86 kB for the simulated car's 722 beams against 3.1 kB
// for the scan itself at rest (CompactScan: its floats coded without loss), and only a few keyframes are aligned at any time (the newest, loop
// candidates, their context). So at most `capacity` stay prepared, the most recently asked
// for; the others keep their scan and are prepared again when asked, which gives the same
// PreparedScan (preparation is deterministic).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
#include <utility>
#include <vector>

#include "laser_loop_closure/core/alignment/scan_aligner.hpp"
#include "laser_loop_closure/core/io/compact_scan.hpp"

namespace llc {

/// get() may be called from several threads at once. A reference it returns stays valid until
/// the next call of a non-const member; those let go only of entries no get() asked for since
/// the last trim(), so a reference taken during one step of the caller survives the add() that
/// ends it.
class PreparedScanCache {
 public:
  /// capacity 0: every scan stays prepared (no scan kept, nothing prepared twice).
  explicit PreparedScanCache(std::size_t capacity = 0) : capacity_(capacity) {}
  PreparedScanCache(const PreparedScanCache& other);
  PreparedScanCache& operator=(const PreparedScanCache& other);

  std::size_t capacity() const { return capacity_; }
  std::size_t size() const { return entries_.size(); }
  /// Appends a keyframe's entry and trims. `prepared` may be null when `scan` is given (prepared
  /// when first asked for); `scan` null: kept prepared for ever. The scan is kept compact
  /// (CompactScan: the same values, its bearings shared with the entry before's when the same).
  /// Throws std::invalid_argument when both are null. Returns its index.
  std::size_t add(std::shared_ptr<const PreparedScan> prepared, const Scan* scan);
  /// The prepared scan of entry `index`, prepared by `aligner` when it is not held. Throws
  /// std::out_of_range for an unknown index or one released.
  const PreparedScan& get(std::size_t index, const ScanAligner& aligner) const;
  /// Entry `index` exists and was not released.
  bool has(std::size_t index) const;
  /// Lets go of entry `index` for good, scan and all (unknown indices are ignored).
  void release(std::size_t index);
  /// Lets go of the least recently asked for prepared scans, down to the capacity, of those
  /// with a scan to prepare them again and not asked for since the last trim.
  void trim();
  std::size_t heldPrepared() const;   ///< entries prepared now
  std::size_t preparedAgain() const;  ///< scans prepared again after they were let go
  std::size_t restingBytes() const;   ///< bytes of the scans kept to prepare again (CompactScan::bytes)

 private:
  struct Entry {
    std::shared_ptr<const PreparedScan> prepared;
    std::shared_ptr<const CompactScan> scan;
    std::uint64_t last_asked = 0;
  };
  // get() is const and fills the cache: what it changes is mutable, under mutex_.
  std::size_t capacity_ = 0;
  mutable std::vector<Entry> entries_;  ///< one per keyframe; get() fills prepared and last_asked, never resizes it
  mutable std::size_t held_ = 0;
  /// (last_asked, index) of the entries trim() may let go (prepared, with a scan to prepare
  /// again), oldest first: trim() takes from the front, so its cost does not grow with the map.
  mutable std::set<std::pair<std::uint64_t, std::size_t>> evictable_;
  mutable std::uint64_t clock_ = 0;
  std::uint64_t trimmed_at_ = 0;
  mutable std::size_t prepared_again_ = 0;
  std::size_t resting_bytes_ = 0;  ///< CompactScan::bytes of the scans held
  mutable std::mutex mutex_;
};

}  // namespace llc
