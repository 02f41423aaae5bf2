#include "laser_loop_closure/core/slam/prepared_scan_cache.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace llc {

PreparedScanCache::PreparedScanCache(const PreparedScanCache& other) { *this = other; }

PreparedScanCache& PreparedScanCache::operator=(const PreparedScanCache& other) {
  if (this == &other) return *this;
  std::scoped_lock lock(mutex_, other.mutex_);
  capacity_ = other.capacity_;
  entries_ = other.entries_;
  held_ = other.held_;
  evictable_ = other.evictable_;
  clock_ = other.clock_;
  trimmed_at_ = other.trimmed_at_;
  prepared_again_ = other.prepared_again_;
  resting_bytes_ = other.resting_bytes_;
  return *this;
}

std::size_t PreparedScanCache::add(std::shared_ptr<const PreparedScan> prepared, const Scan* scan) {
  if (!prepared && !scan) throw std::invalid_argument("keyframe without a prepared scan or a scan to prepare");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::shared_ptr<const CompactScan> rest;
    if (scan) {
      // The newest entry's scan (entries are only added under this lock): its bearings are likely the same.
      const CompactScan* before = !entries_.empty() ? entries_.back().scan.get() : nullptr;
      rest = std::make_shared<const CompactScan>(*scan, before);
      resting_bytes_ += rest->bytes();
    }
    if (prepared) ++held_;
    const bool evictable = prepared && rest;
    entries_.push_back({std::move(prepared), std::move(rest), ++clock_});
    if (evictable) evictable_.emplace(clock_, entries_.size() - 1);
  }
  trim();
  return entries_.size() - 1;
}

const PreparedScan& PreparedScanCache::get(std::size_t index, const ScanAligner& aligner) const {
  std::shared_ptr<const CompactScan> scan;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (index >= entries_.size()) throw std::out_of_range("no keyframe " + std::to_string(index));
    Entry& entry = entries_[index];
    if (entry.prepared) {
      if (entry.scan) evictable_.erase({entry.last_asked, index});
      entry.last_asked = ++clock_;
      if (entry.scan) evictable_.emplace(entry.last_asked, index);
      return *entry.prepared;
    }
    if (!entry.scan) throw std::out_of_range("keyframe " + std::to_string(index) + ": its scan was let go (releasePrepared)");
    scan = entry.scan;
  }
  // Prepared outside the lock: other threads' keyframes need not wait for this one.
  std::shared_ptr<const PreparedScan> made = aligner.prepare(scan->scan());
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& entry = entries_[index];
  if (!entry.prepared) {  // else another thread prepared it meanwhile: the same scan, theirs kept
    entry.prepared = std::move(made);
    ++held_;
    ++prepared_again_;
  } else {
    evictable_.erase({entry.last_asked, index});
  }
  entry.last_asked = ++clock_;
  evictable_.emplace(entry.last_asked, index);
  return *entry.prepared;
}

bool PreparedScanCache::has(std::size_t index) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return index < entries_.size() && (entries_[index].prepared || entries_[index].scan);
}

void PreparedScanCache::release(std::size_t index) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (index >= entries_.size()) return;
  if (entries_[index].prepared) --held_;
  if (entries_[index].prepared && entries_[index].scan) evictable_.erase({entries_[index].last_asked, index});
  if (entries_[index].scan) resting_bytes_ -= entries_[index].scan->bytes();
  entries_[index].prepared.reset();
  entries_[index].scan.reset();
}

void PreparedScanCache::trim() {
  std::lock_guard<std::mutex> lock(mutex_);
  // The least recently asked first; one asked since the last trim (a caller may hold its
  // reference) ends the walk, as every entry after it was asked later still.
  while (capacity_ > 0 && held_ > capacity_ && !evictable_.empty() && evictable_.begin()->first <= trimmed_at_) {
    entries_[evictable_.begin()->second].prepared.reset();
    evictable_.erase(evictable_.begin());
    --held_;
  }
  trimmed_at_ = clock_;
}

std::size_t PreparedScanCache::heldPrepared() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return held_;
}

std::size_t PreparedScanCache::restingBytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return resting_bytes_;
}

std::size_t PreparedScanCache::preparedAgain() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return prepared_again_;
}

}  // namespace llc
