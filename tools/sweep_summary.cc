#include "tools/sweep_summary.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "engine/errors.h"
#include "haptics/hdf5_id.h"
#include "haptics/session.h"

namespace hapvox::cli {
namespace {

// A finished session's numbers, as text ("" where it has none).
struct SessionNumbers {
  std::string tool_diameter_mm, youngs_modulus_pa, peak_force_n, rms_force_n, contact_time_s,
      compute_p99_us, lateness_p99_us, mass_drift_units;
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
  n.tool_diameter_mm = attribute("tool_diameter_mm");
  if (n.tool_diameter_mm.empty() && !attribute("tool_radius_mm").empty()) {  // FEM sessions
    char text[32];
    std::snprintf(text, sizeof text, "%.17g", 2.0 * std::stod(attribute("tool_radius_mm")));
    n.tool_diameter_mm = text;
  }
  n.youngs_modulus_pa =
      attribute("youngs_modulus_pa");  // the command line's (materials: per tissue)
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

struct Column {
  const char* name;
  bool number;
};
constexpr std::array<Column, 16> kColumns = {{{"id", false},
                                              {"status", false},
                                              {"trace", false},
                                              {"volume", false},
                                              {"model", false},
                                              {"materials", false},
                                              {"options", false},
                                              {"tool_diameter_mm", true},
                                              {"youngs_modulus_pa", true},
                                              {"peak_force_n", true},
                                              {"rms_force_n", true},
                                              {"contact_time_s", true},
                                              {"compute_p99_us", true},
                                              {"lateness_p99_us", true},
                                              {"mass_drift_units", true},
                                              {"error", false}}};

// Each row's cells as text, in kColumns' order ("" where a row has no value).
using SweepTable = std::vector<std::vector<std::string>>;

SweepTable sweep_table(const std::vector<haptics::SweepRow>& rows,
                       const std::vector<SweepOutcome>& outcomes) {
  SweepTable table;
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
    table.push_back({outcome.id, outcome.status, row.trace, row.volume, row.model, row.materials,
                     options, n.tool_diameter_mm, n.youngs_modulus_pa, n.peak_force_n,
                     n.rms_force_n, n.contact_time_s, n.compute_p99_us, n.lateness_p99_us,
                     n.mass_drift_units, outcome.error});
  }
  return table;
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

namespace {

// Writes PATH through PATH.partial, renamed once whole; removed when writing failed. (Only
// one sweep writes DIR's summaries at a time: tools/sweep_plan.h's SweepDirLock.)
template <typename Write>
void write_through_partial(const std::string& path, Write write) {
  engine::io::OutputFile out(path);
  try {
    write(out);
    out.commit();
  } catch (...) {
    out.discard();
    throw;
  }
}

void write_csv(engine::io::OutputFile& file, const SweepTable& table) {
  {
    std::ostringstream out;
    for (std::size_t c = 0; c < kColumns.size(); ++c) {
      out << kColumns[c].name << (c + 1 < kColumns.size() ? ',' : '\n');
    }
    for (const std::vector<std::string>& row : table) {
      for (std::size_t c = 0; c < row.size(); ++c) {
        out << csv_cell(row[c]) << (c + 1 < row.size() ? ',' : '\n');
      }
    }
    const std::string text = out.str();
    file.write(text.data(), text.size());
  }
}

void write_h5(engine::io::OutputFile& out, const SweepTable& table) {
  const std::string& path = out.path();
  {
    haptics::H5Id file(haptics::create_hdf5_output(out), H5Fclose);
    const hsize_t count = table.size();
    haptics::H5Id space(H5Screate_simple(1, &count, nullptr), H5Sclose);
    bool ok = true;
    std::string names;
    for (std::size_t c = 0; c < kColumns.size(); ++c) {
      names += (c > 0 ? "," : "") + std::string(kColumns[c].name);
      if (kColumns[c].number) {
        std::vector<double> values(table.size());
        for (std::size_t r = 0; r < table.size(); ++r) {
          const std::string& cell = table[r][c];
          values[r] = cell.empty() ? std::nan("") : std::stod(cell);
        }
        haptics::H5Id set(H5Dcreate2(file.get(), kColumns[c].name, H5T_IEEE_F64LE, space.get(),
                                     H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                          H5Dclose);
        ok = ok && set.valid() &&
             H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) >=
                 0;
      } else {
        std::size_t width = 1;
        for (const auto& row : table) width = std::max(width, row[c].size() + 1);
        std::vector<char> text(width * table.size(), '\0');
        for (std::size_t r = 0; r < table.size(); ++r) {
          std::copy(table[r][c].begin(), table[r][c].end(), text.begin() + r * width);
        }
        haptics::H5Id type(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(type.get(), width);
        H5Tset_cset(type.get(), H5T_CSET_UTF8);
        haptics::H5Id set(H5Dcreate2(file.get(), kColumns[c].name, type.get(), space.get(),
                                     H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                          H5Dclose);
        ok = ok && set.valid() &&
             H5Dwrite(set.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()) >= 0;
      }
    }
    // Variable-length: h5py reads it as a str.
    haptics::H5Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), H5T_VARIABLE);
    H5Tset_cset(type.get(), H5T_CSET_UTF8);
    haptics::H5Id scalar(H5Screate(H5S_SCALAR), H5Sclose);
    haptics::H5Id attribute(
        H5Acreate2(file.get(), "columns", type.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT),
        H5Aclose);
    const char* text = names.c_str();
    ok = ok && attribute.valid() && H5Awrite(attribute.get(), type.get(), &text) >= 0;
    ok = attribute.close() && ok;
    if (!ok || !file.close()) throw InputError(path, "cannot be written");
  }
}

}  // namespace

void write_sweep_summaries(const std::string& dir, const std::vector<haptics::SweepRow>& rows,
                           const std::vector<SweepOutcome>& outcomes) {
  const SweepTable table = sweep_table(rows, outcomes);
  const std::string csv = dir + "/summary.csv", h5 = dir + "/summary.h5";
  write_through_partial(csv, [&](engine::io::OutputFile& out) { write_csv(out, table); });
  write_through_partial(h5, [&](engine::io::OutputFile& out) { write_h5(out, table); });
}

}  // namespace hapvox::cli
