#include "tools/bench.h"

#include <sys/utsname.h>
#include <unistd.h>

#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "haptics/session.h"

namespace hapvox::cli {

std::vector<int> parse_int_list(const std::string& text, const std::string& flag) {
  std::vector<int> values;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) {
    try {
      std::size_t used = 0;
      const int v = std::stoi(part, &used);
      if (used != part.size() || v <= 0) throw std::invalid_argument(part);
      values.push_back(v);
    } catch (const std::exception&) {
      throw InputError(flag, "expected positive integers separated by commas, got '" + text + "'");
    }
  }
  if (values.empty()) throw InputError(flag, "empty list");
  return values;
}

namespace {

// Collects the median of each benchmark's repetitions.
class MedianCollector : public benchmark::BenchmarkReporter {
 public:
  bool ReportContext(const Context&) override { return true; }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      // Adjusted real time is per iteration, in the run's time unit (ns here). With one
      // repetition there is no median aggregate: the single run stands for it.
      const std::string& name = run.run_name.function_name;
      if (run.run_type == Run::RT_Aggregate && run.aggregate_name == "median") {
        median_ns[name] = run.GetAdjustedRealTime();
      } else if (run.run_type == Run::RT_Iteration && !median_ns.count(name)) {
        median_ns[name] = run.GetAdjustedRealTime();
      }
    }
  }
  std::map<std::string, double> median_ns;
};

}  // namespace

void init_benchmark(double min_time_s, int repetitions) {
  static bool initialized = false;
  if (initialized) return;
  initialized = true;
  // Google Benchmark keeps pointers into argv: the strings must outlive the process.
  static std::string min_time = "--benchmark_min_time=" + std::to_string(min_time_s);
  static std::string reps = "--benchmark_repetitions=" + std::to_string(repetitions);
  static std::string aggregates = "--benchmark_report_aggregates_only=true";
  static std::string name = "hapvox-bench";
  std::vector<char*> argv = {name.data(), min_time.data(), reps.data(), aggregates.data()};
  int argc = static_cast<int>(argv.size());
  benchmark::Initialize(&argc, argv.data());
}

std::map<std::string, double> measure(const std::vector<std::pair<std::string, BenchFn>>& fns) {
  benchmark::ClearRegisteredBenchmarks();
  for (const auto& [name, fn] : fns) {
    benchmark::RegisterBenchmark(name.c_str(), fn)->Unit(benchmark::kNanosecond)->UseRealTime();
  }
  MedianCollector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::ClearRegisteredBenchmarks();
  return collector.median_ns;
}

std::map<std::string, double> measure_manual_time(
    const std::vector<std::pair<std::string, BenchFn>>& fns, int iterations) {
  benchmark::ClearRegisteredBenchmarks();
  for (const auto& [name, fn] : fns) {
    benchmark::RegisterBenchmark(name.c_str(), fn)
        ->Unit(benchmark::kNanosecond)
        ->UseManualTime()
        ->Iterations(iterations);
  }
  MedianCollector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  benchmark::ClearRegisteredBenchmarks();
  return collector.median_ns;
}

namespace {

std::string read_first_line_with(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key, 0) == 0) {
      const auto colon = line.find(':');
      return colon == std::string::npos ? line
                                        : line.substr(line.find_first_not_of(" \t", colon + 1));
    }
  }
  return "unknown";
}

}  // namespace

std::vector<std::pair<std::string, std::string>> machine_description() {
  std::vector<std::pair<std::string, std::string>> m;
  m.emplace_back("cpu", read_first_line_with("/proc/cpuinfo", "model name"));
  m.emplace_back("online_cpus", std::to_string(sysconf(_SC_NPROCESSORS_ONLN)));
  m.emplace_back("memory", read_first_line_with("/proc/meminfo", "MemTotal"));
  utsname u{};
  if (uname(&u) == 0)
    m.emplace_back("kernel", std::string(u.sysname) + " " + u.release + " " + u.machine);
  m.emplace_back("compiler", "gcc " __VERSION__);
#ifdef NDEBUG
  m.emplace_back("build", "release (NDEBUG)");
#else
  m.emplace_back("build", "debug");
#endif
  for (const auto& [name, version] : haptics::library_versions()) m.emplace_back(name, version);
  char date[64];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  m.emplace_back("date", date);
  return m;
}

std::string machine_json(const std::vector<std::pair<std::string, std::string>>& machine) {
  std::string json = "{";
  for (std::size_t i = 0; i < machine.size(); ++i) {
    json += (i ? ", " : "") + json_string(machine[i].first) + ": " + json_string(machine[i].second);
  }
  return json + "}";
}

std::string machine_csv_comments(const std::vector<std::pair<std::string, std::string>>& machine) {
  std::string text;
  for (const auto& [key, value] : machine) text += "# " + key + ": " + value + "\n";
  return text;
}

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream out;
  out.precision(10);
  out << v;
  return out.str();
}

// Writes PATH.partial, then renames: a failed run leaves no half-written file.
void write_atomically(const std::string& path, const std::string& text) {
  engine::io::write_text_atomically(path, text);
}

engine::DensityField make_half_block(int n) {
  engine::initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(n - 1, n - 1, n / 2 - 1)),
                    1.0f, true);
  grid->tree().voxelizeActiveTiles();
  return engine::DensityField(grid, Eigen::Vector3d::Ones(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3i::Constant(n));
}

std::string find_bundled(const std::string& path) {
  namespace fs = std::filesystem;
  const bool bundled = path.rfind("data/", 0) == 0 || path.rfind("traces/", 0) == 0;
  std::error_code ec;
  if (!bundled || fs::exists(path, ec)) return path;
  std::vector<fs::path> roots;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    roots.push_back(exe.parent_path() / ".." / "..");                // build/tools/hapvox
    roots.push_back(exe.parent_path() / ".." / "share" / "hapvox");  // prefix/bin/hapvox
  }
#ifdef HAPVOX_SOURCE_DIR
  roots.emplace_back(HAPVOX_SOURCE_DIR);
#endif
#ifdef HAPVOX_SHARE_DIR
  roots.emplace_back(HAPVOX_SHARE_DIR);
#endif
  for (const fs::path& root : roots) {
    const fs::path candidate = root / path;
    if (fs::is_regular_file(candidate, ec)) return candidate.lexically_normal().string();
  }
  return path;
}

}  // namespace hapvox::cli
