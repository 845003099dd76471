#include "tools/sweep_summary.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include "engine/errors.h"
#include "haptics/session.h"

namespace hapvox::cli {
namespace {

// A finished session's numbers, as text ("" where it has none).
struct SessionNumbers {
  std::string peak_force_n, rms_force_n, contact_time_s, compute_p99_us, lateness_p99_us,
      mass_drift_units;
};

SessionNumbers numbers_of(const std::string& session) {
  const haptics::SessionInfo info = haptics::read_session_info(session);
  const std::map<std::string, std::string> attributes(info.attributes.begin(),
                                                      info.attributes.end());
  auto attribute = [&](const char* name) {
    const auto it = attributes.find(name);
    return it == attributes.end() ? std::string() : it->second;
  };
  SessionNumbers n;
  n.peak_force_n = attribute("summary_peak_force_n");
  n.contact_time_s = attribute("summary_contact_time_s");
  n.compute_p99_us = attribute("summary_compute_p99_us");
  n.lateness_p99_us = attribute("summary_lateness_p99_us");
  const std::string initial = attribute("summary_initial_mass_units");
  const std::string final_mass = attribute("summary_final_mass_units");
  if (!initial.empty() && !final_mass.empty()) {
    n.mass_drift_units = std::to_string(std::stoll(final_mass) - std::stoll(initial));
  }
  // RMS of the force's magnitude over every tick.
  const std::vector<double> force = haptics::read_session_column(session, "/force_n");
  double sum_squares = 0.0;
  for (const double f : force) sum_squares += f * f;
  const std::size_t ticks = force.size() / 3;
  if (ticks > 0) {
    char text[32];
    std::snprintf(text, sizeof text, "%.9g", std::sqrt(sum_squares / static_cast<double>(ticks)));
    n.rms_force_n = text;
  }
  return n;
}

}  // namespace

std::string csv_cell(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

void write_sweep_summary(const std::string& path, const std::vector<haptics::SweepRow>& rows,
                         const std::vector<SweepOutcome>& outcomes) {
  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial);
    if (!out) throw InputError(path, "cannot be written");
    out << "id,status,trace,volume,model,materials,options,peak_force_n,rms_force_n,"
           "contact_time_s,compute_p99_us,lateness_p99_us,mass_drift_units,error\n";
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const haptics::SweepRow& row = rows[i];
      const SweepOutcome& outcome = outcomes[i];
      std::string options;
      for (const auto& [name, value] : row.options) {
        if (!options.empty()) options += ' ';
        options += "--" + name + (value.empty() ? "" : " " + value);
      }
      SessionNumbers n;
      if (outcome.status == "done") n = numbers_of(outcome.session);
      for (const std::string& cell :
           {outcome.id, outcome.status, row.trace, row.volume, row.model, row.materials, options,
            n.peak_force_n, n.rms_force_n, n.contact_time_s, n.compute_p99_us, n.lateness_p99_us,
            n.mass_drift_units}) {
        out << csv_cell(cell) << ',';
      }
      out << csv_cell(outcome.error) << '\n';
    }
    if (!out.flush()) throw InputError(path, "cannot be written");
  }
  std::filesystem::rename(partial, path);
}

}  // namespace hapvox::cli
