// A simulator's haptic thread with hapvox inside: its own 1 kHz loop, its own device (here a
// callback that plays a recorded trace back, where a real application reads its device's
// driver), and hapvox's force stage stepped once per tick.
//
//   embed VOLUME TRACE [--no-pace] [--compare SESSION.h5] [--forces OUT.csv]
//
// --compare checks every force against a session `hapvox replay TRACE --volume VOLUME`
// wrote: lockstep replays and this loop run the same force stage, so they must agree bit
// for bit (exit 1 at the first tick that does not).

#include <hapvox/hapvox.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace {

int usage() {
  std::fprintf(stderr,
               "usage: embed VOLUME TRACE [--no-pace] [--compare SESSION.h5] [--forces OUT.csv]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) return usage();
  const std::string volume_path = argv[1];
  const std::string trace_path = argv[2];
  bool pace = true;
  std::string compare_path, forces_path;
  for (int i = 3; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--no-pace") {
      pace = false;
    } else if (arg == "--compare" && i + 1 < argc) {
      compare_path = argv[++i];
    } else if (arg == "--forces" && i + 1 < argc) {
      forces_path = argv[++i];
    } else {
      return usage();
    }
  }

  try {
    std::printf("hapvox %s (headers %s)\n", hapvox::version(), HAPVOX_VERSION_STRING);
    const hapvox::Volume volume = hapvox::Volume::load(volume_path);
    const hapvox::Model model = hapvox::Model::voxel(volume);  // `hapvox replay`'s defaults

    // The application's device: a callback giving the tool's position for each tick.
    const std::vector<hapvox::ToolSample> recorded =
        hapvox::Trace::load(trace_path).resampled(1000.0);
    const std::function<hapvox::ToolSample(std::size_t)> device = [&](std::size_t tick) {
      return recorded[tick];
    };

    hapvox::ForceStage stage(model);  // made once: step() then allocates nothing
    std::vector<hapvox::ForceTick> ticks(recorded.size());
    const auto period = std::chrono::microseconds(1000);
    auto deadline = std::chrono::steady_clock::now();
    std::size_t late = 0;
    for (std::size_t tick = 0; tick < recorded.size(); ++tick) {
      if (pace) {
        deadline += period;
        if (std::chrono::steady_clock::now() > deadline) ++late;
        std::this_thread::sleep_until(deadline);
      }
      ticks[tick] = stage.step(device(tick));
      // A real application sends ticks[tick].force_device_n to its device here.
    }
    double peak = 0.0;
    for (const hapvox::ForceTick& t : ticks) {
      const double f = std::sqrt(t.force_n[0] * t.force_n[0] + t.force_n[1] * t.force_n[1] +
                                 t.force_n[2] * t.force_n[2]);
      peak = f > peak ? f : peak;
    }
    std::printf("%zu ticks at 1 kHz%s, peak force %.4f N, %zu ticks started late\n", ticks.size(),
                pace ? " (paced by the clock)" : "", peak, late);

    if (!forces_path.empty()) {
      std::FILE* out = std::fopen(forces_path.c_str(), "w");
      if (out == nullptr) {
        std::fprintf(stderr, "embed: error: %s: cannot write\n", forces_path.c_str());
        return 2;
      }
      std::fprintf(out, "tick,fx_n,fy_n,fz_n\n");
      for (std::size_t k = 0; k < ticks.size(); ++k) {
        std::fprintf(out, "%zu,%.17g,%.17g,%.17g\n", k, ticks[k].force_n[0], ticks[k].force_n[1],
                     ticks[k].force_n[2]);
      }
      std::fclose(out);
    }

    if (!compare_path.empty()) {
      const hapvox::Session session = hapvox::Session::open(compare_path);
      const hapvox::Dataset& force = session.dataset("force_n");
      if (force.shape.size() != 2 || force.shape[0] != ticks.size() || force.shape[1] != 3) {
        std::fprintf(stderr, "embed: %s has %zu ticks, this loop ran %zu\n", compare_path.c_str(),
                     force.shape.empty() ? 0 : force.shape[0], ticks.size());
        return 1;
      }
      for (std::size_t k = 0; k < ticks.size(); ++k) {
        for (std::size_t axis = 0; axis < 3; ++axis) {
          const double replayed = force.values[3 * k + axis];
          if (std::memcmp(&replayed, &ticks[k].force_n[axis], sizeof(double)) != 0) {
            std::fprintf(stderr, "embed: tick %zu axis %zu: %.17g here, %.17g in %s\n", k, axis,
                         ticks[k].force_n[axis], replayed, compare_path.c_str());
            return 1;
          }
        }
      }
      std::printf("forces equal %s's bit for bit on all %zu ticks\n", compare_path.c_str(),
                  ticks.size());
    }
  } catch (const hapvox::InputError& e) {
    std::fprintf(stderr, "embed: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
