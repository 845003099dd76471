#include "haptics/bridge_sequence.h"

#include <algorithm>

namespace hapvox::haptics {

Arrival SequenceWindow::arrive(std::uint32_t sequence, std::uint32_t extra_jump) {
  ++received_;
  if (!started_) {
    started_ = true;
    newest_ = sequence;
    seen_ = 1;
    ++fresh_;
    return Arrival::fresh;
  }
  // Modular distance: ahead in [1, 2^31) is newer; everything else is older or the same.
  const std::uint32_t ahead = sequence - newest_;
  if (ahead != 0 && ahead < (1u << 31)) {
    const std::uint64_t widest =
        std::min<std::uint64_t>(std::uint64_t{max_jump_} + extra_jump, kSequenceJumpCeiling);
    if (ahead > widest) {  // not this stream's next number: the stream stays as it was
      ++out_of_window_;
      return Arrival::out_of_window;
    }
    // The numbers skipped are lost until they turn up; the window slides past them.
    lost_ += ahead - 1;
    seen_ = ahead >= 64 ? 0 : seen_ << ahead;
    seen_ |= 1;
    newest_ = sequence;
    ++fresh_;
    return Arrival::fresh;
  }
  const std::uint32_t behind = newest_ - sequence;
  if (behind > max_jump_) {
    ++out_of_window_;
    return Arrival::out_of_window;
  }
  if (behind < 64) {
    const std::uint64_t bit = std::uint64_t{1} << behind;
    if ((seen_ & bit) != 0) {
      ++duplicates_;
      return Arrival::duplicate;
    }
    seen_ |= bit;
    if (lost_ > 0) --lost_;  // counted lost when skipped; it came late instead
  }
  ++late_;
  return Arrival::late;
}

}  // namespace hapvox::haptics
