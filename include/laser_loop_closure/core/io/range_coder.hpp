// An adaptive binary range coder (the scheme of LZMA's: 11-bit probabilities that follow the
// bits they code, a 32-bit range, carries through a cached byte) and signed integers coded
// through it. Written here because no Debian library exposes one: zlib's Huffman codes spend at
// least a bit per byte of a varint, where a scan's nearly always zero direction codes need a
// twentieth of one and its range residuals about five bits (packScan).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace llc {

namespace range_coding {
constexpr int kProbabilityBits = 11;
constexpr std::uint32_t kOne = 1u << kProbabilityBits;
constexpr int kAdaptShift = 4;  // a sixteenth: faster than LZMA's 32nd, for messages of a few hundred symbols
constexpr std::uint32_t kTop = 1u << 24;
}  // namespace range_coding

/// The probability of a 0 (in 1/2048), moved a sixteenth of the way towards each bit coded: a
/// model learns within the few hundred symbols of one scan.
struct BitModel {
  std::uint16_t zero = 1024;
  void adapt(bool bit) {
    using namespace range_coding;
    if (bit) zero = std::uint16_t(zero - (zero >> kAdaptShift));
    else zero = std::uint16_t(zero + ((kOne - zero) >> kAdaptShift));
  }
};

class RangeEncoder {
 public:
  void encode(BitModel& model, bool bit);
  void encodeDirect(bool bit);  ///< a bit at even odds, no model
  /// The coded bytes (the coder is spent after this).
  std::vector<std::uint8_t> finish();

 private:
  void shiftLow();
  std::uint64_t low_ = 0;
  std::uint32_t range_ = 0xFFFFFFFFu;
  std::uint8_t cache_ = 0;
  std::uint64_t cache_size_ = 1;
  bool first_ = true;  ///< LZMA's first byte is always 0: not written
  std::vector<std::uint8_t> out_;
};

/// Reads what RangeEncoder wrote. Past the end it reads zeros and says so (overrun()): the
/// caller refuses such data; nothing here can fail otherwise, whatever the bytes.
class RangeDecoder {
 public:
  RangeDecoder(const std::uint8_t* data, std::size_t size);
  // Inline: a packed scan's reading is most of these calls.
  bool decode(BitModel& model) {
    const std::uint32_t bound = (range_ >> range_coding::kProbabilityBits) * model.zero;
    const bool bit = code_ >= bound;
    if (bit) code_ -= bound, range_ -= bound;
    else range_ = bound;
    model.adapt(bit);
    normalize();
    return bit;
  }
  bool decodeDirect() {
    range_ >>= 1;
    const bool bit = code_ >= range_;
    if (bit) code_ -= range_;
    normalize();
    return bit;
  }
  /// Bytes taken so far (beyond size() when the data ran out).
  std::size_t consumed() const { return at_; }
  bool overrun() const { return at_ > size_; }

 private:
  std::uint8_t next() { return at_ < size_ ? data_[at_++] : (++at_, 0); }
  void normalize() {
    while (range_ < range_coding::kTop) range_ <<= 8, code_ = (code_ << 8) | next();
  }
  const std::uint8_t* data_;
  std::size_t size_, at_ = 0;
  std::uint32_t range_ = 0xFFFFFFFFu, code_ = 0;
};

/// The next value of a sequence from its last ones: the last (noise about a level), the last
/// two extrapolated (a steady slope: a wall seen at a slant), or that unless they differ by more
/// than `jump` (an edge), whichever has missed least lately (the misses' sum decaying by 1/8 a
/// value, each miss counted up to `miss_cap`: one edge's miss of thousands must not outweigh
/// the next thirty values' misses of a few). Integers only, so that writer and reader predict
/// alike on any machine.
class SequencePredictor {
 public:
  SequencePredictor(std::int64_t jump, std::int64_t miss_cap) : jump_(jump), miss_cap_(std::min(miss_cap, std::int64_t(1) << 56)) {}
  std::int64_t next() const {
    if (count_ < 2) return last_;
    const std::array<std::int64_t, 3> guesses = guessesOf();
    return guesses[std::size_t(std::min_element(misses_.begin(), misses_.end()) - misses_.begin())];
  }
  /// Values should stay within +-2^60 (sums of misses must not overflow).
  void add(std::int64_t value) {
    if (count_ >= 2) {
      const std::array<std::int64_t, 3> guesses = guessesOf();
      for (std::size_t k = 0; k < 3; ++k) {
        const std::int64_t miss = value > guesses[k] ? value - guesses[k] : guesses[k] - value;
        misses_[k] += std::min(miss, miss_cap_) - (misses_[k] >> 3);
      }
    }
    before_ = last_, last_ = value, ++count_;
  }

 private:
  std::array<std::int64_t, 3> guessesOf() const {
    const std::int64_t slope = last_ - before_;
    return {last_, last_ + slope, (slope > jump_ || slope < -jump_) ? last_ : last_ + slope};
  }
  std::int64_t jump_, miss_cap_, last_ = 0, before_ = 0, count_ = 0;
  std::array<std::int64_t, 3> misses_{};
};

/// Signed integers as adaptive bits: zero or not, the sign, the magnitude's binary exponent in
/// unary (one model per position), its two leading mantissa bits modelled per exponent and the
/// rest at even odds. Small values cost little once they are common; |value| < 2^62
/// (std::invalid_argument beyond).
class IntegerModel {
 public:
  void encode(RangeEncoder& coder, std::int64_t value);
  /// False on an exponent of 62 or more (corrupt data).
  bool decode(RangeDecoder& coder, std::int64_t* value);

 private:
  static constexpr int kMostExponent = 62;
  BitModel nonzero_, negative_;
  std::array<BitModel, kMostExponent + 1> exponent_;
  std::array<std::array<BitModel, 2>, kMostExponent + 1> mantissa_;
};

}  // namespace llc
