#include "laser_loop_closure/core/io/range_coder.hpp"

#include <stdexcept>

namespace llc {
using namespace range_coding;

void RangeEncoder::encode(BitModel& model, bool bit) {
  const std::uint32_t bound = (range_ >> kProbabilityBits) * model.zero;
  if (bit) low_ += bound, range_ -= bound;
  else range_ = bound;
  model.adapt(bit);
  while (range_ < kTop) range_ <<= 8, shiftLow();
}

void RangeEncoder::encodeDirect(bool bit) {
  range_ >>= 1;
  if (bit) low_ += range_;
  while (range_ < kTop) range_ <<= 8, shiftLow();
}

void RangeEncoder::shiftLow() {
  // A byte is written once no carry can reach it: bytes of 0xFF wait (cache_size_) until the
  // next one settles whether a carry ripples through them.
  if (std::uint32_t(low_) < 0xFF000000u || (low_ >> 32) != 0) {
    const auto carry = std::uint8_t(low_ >> 32);
    std::uint8_t byte = cache_;
    do {
      if (!first_) out_.push_back(std::uint8_t(byte + carry));
      first_ = false;
      byte = 0xFF;
    } while (--cache_size_ != 0);
    cache_ = std::uint8_t(low_ >> 24);
  }
  ++cache_size_;
  low_ = (low_ & 0x00FFFFFFu) << 8;
}

std::vector<std::uint8_t> RangeEncoder::finish() {
  for (int k = 0; k < 5; ++k) shiftLow();
  return std::move(out_);
}

RangeDecoder::RangeDecoder(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {
  for (int k = 0; k < 4; ++k) code_ = (code_ << 8) | next();
}

void IntegerModel::encode(RangeEncoder& coder, std::int64_t value) {
  coder.encode(nonzero_, value != 0);
  if (value == 0) return;
  coder.encode(negative_, value < 0);
  const std::uint64_t magnitude = value < 0 ? std::uint64_t(0) - std::uint64_t(value) : std::uint64_t(value);
  int exponent = 0;
  while (exponent < 63 && (magnitude >> (exponent + 1)) != 0) ++exponent;
  if (exponent >= kMostExponent) throw std::invalid_argument("range coder: an integer of 2^62 or more");
  for (int k = 0; k < exponent; ++k) coder.encode(exponent_[std::size_t(k)], true);
  coder.encode(exponent_[std::size_t(exponent)], false);
  for (int k = exponent - 1; k >= 0; --k) {
    const bool bit = (magnitude >> k) & 1u;
    const int lead = exponent - 1 - k;  // 0 for the bit after the leading one
    if (lead < 2) coder.encode(mantissa_[std::size_t(exponent)][std::size_t(lead)], bit);
    else coder.encodeDirect(bit);
  }
}

bool IntegerModel::decode(RangeDecoder& coder, std::int64_t* value) {
  if (!coder.decode(nonzero_)) return *value = 0, true;
  const bool negative = coder.decode(negative_);
  int exponent = 0;
  while (coder.decode(exponent_[std::size_t(exponent)]))
    if (++exponent >= kMostExponent) return false;
  std::uint64_t magnitude = 1;
  for (int k = exponent - 1; k >= 0; --k) {
    const int lead = exponent - 1 - k;
    const bool bit = lead < 2 ? coder.decode(mantissa_[std::size_t(exponent)][std::size_t(lead)]) : coder.decodeDirect();
    magnitude = (magnitude << 1) | (bit ? 1u : 0u);
  }
  *value = negative ? -std::int64_t(magnitude) : std::int64_t(magnitude);
  return true;
}

}  // namespace llc
