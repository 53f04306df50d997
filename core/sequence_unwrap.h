#pragma once
// Unwraps a device's short rolling counter (GigE Vision 16-bit block ids, the
// Sensel's 8-bit counter) into a 64-bit sequence, and says how many values were
// skipped since the previous one, so drops are counted by the device's own
// numbering rather than by what the host happened to see.
#include <cstdint>

namespace pvcap {

class SequenceUnwrapper {
 public:
  // `bits`: counter width. `zero_is_skipped`: GigE Vision 1.x never uses block id 0,
  // so 65535 is followed by 1.
  SequenceUnwrapper(int bits, bool zero_is_skipped) : modulus_(std::uint64_t{1} << bits), skip_zero_(zero_is_skipped) {}

  struct Step {
    std::uint64_t sequence = 0;  // unwrapped value (the first raw value is its own sequence)
    std::uint64_t missing = 0;   // values skipped since the previous newest one
    bool out_of_order = false;   // repeated (sequence == newest) or late (sequence < newest)
  };

  Step next(std::uint64_t raw) {
    raw %= modulus_;
    if (!started_) {
      started_ = true;
      last_raw_ = raw;
      last_seq_ = raw;
      return {raw, 0, false};
    }
    std::uint64_t delta = (raw + modulus_ - last_raw_) % modulus_;
    if (delta == 0) return {last_seq_, 0, true};
    if (delta > modulus_ / 2) {  // behind the newest: a late frame; say which one it is
      std::uint64_t back = (last_raw_ + modulus_ - raw) % modulus_;
      if (skip_zero_ && raw > last_raw_) back -= 1;  // the wrap lies between them
      return {back <= last_seq_ ? last_seq_ - back : 0, 0, true};
    }
    if (skip_zero_ && raw < last_raw_) delta -= 1;  // crossed the wrap, where 0 does not exist
    last_raw_ = raw;
    last_seq_ += delta;
    return {last_seq_, delta - 1, false};
  }

 private:
  std::uint64_t modulus_;
  bool skip_zero_;
  bool started_ = false;
  std::uint64_t last_raw_ = 0;
  std::uint64_t last_seq_ = 0;
};

}  // namespace pvcap
