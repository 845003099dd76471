#include "haptics/device.h"

#include <thread>

namespace hapvox::haptics {

namespace {
// Sleeping overshoots by up to the timer slack; the last stretch is spun.
constexpr auto kSpinWindow = std::chrono::microseconds(150);
}  // namespace

void sleep_then_spin_until(Device::Clock::time_point deadline) {
  const auto now = Device::Clock::now();
  if (deadline - now > kSpinWindow) std::this_thread::sleep_until(deadline - kSpinWindow);
  while (Device::Clock::now() < deadline) {
  }
}

Device::Clock::time_point Device::wait_for_tick(std::size_t, Clock::time_point deadline) {
  sleep_then_spin_until(deadline);
  return deadline;
}

}  // namespace hapvox::haptics
