#include "haptics/deletion_lag.h"

#include <algorithm>

#include "haptics/replay_summary.h"

namespace hapvox::haptics {

DeletionLags deletion_lags(const std::vector<TickTimes>& ticks) {
  DeletionLags out;
  std::vector<std::int64_t> sent_ns;  // each event's, in event order
  std::vector<std::size_t> sent_tick;
  std::vector<double> lag_ms, lag_ticks;
  std::size_t seen = 0;  // events whose lag is known
  for (std::size_t k = 0; k < ticks.size(); ++k) {
    const TickTimes& t = ticks[k];
    // Read at the tick's start: events up to published_event are in the field it reads.
    while (seen < sent_ns.size() && static_cast<std::int64_t>(seen) <= t.published_event) {
      lag_ms.push_back(1e-6 * static_cast<double>(t.read_ns - sent_ns[seen]));
      lag_ticks.push_back(static_cast<double>(k - sent_tick[seen]));
      ++seen;
    }
    if (t.plastic_event) {
      sent_ns.push_back(t.sent_ns);
      sent_tick.push_back(k);
    }
  }
  out.events = sent_ns.size();
  out.unseen = sent_ns.size() - seen;
  if (!lag_ms.empty()) {
    out.p50_ms = haptics::percentile(lag_ms, 50.0);
    out.p99_ms = haptics::percentile(lag_ms, 99.0);
    out.max_ms = *std::max_element(lag_ms.begin(), lag_ms.end());
    out.p99_ticks = haptics::percentile(lag_ticks, 99.0);
  }
  return out;
}

}  // namespace hapvox::haptics
