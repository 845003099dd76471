// hapvox bench fem: the proxy-mesh FEM (engine/fem) against tet count and at the vertex
// counts of Nakao et al.'s Table 1, ours beside naive baselines measured in the same run:
// mesh build (conforming four-spheres mesh), factorisation (LinearFem construction), the
// linear step (one prefactored solve with new loads; naive: unpreconditioned CG on K_FF to
// the co-rotational PCG's tolerance, and re-factorising K_FF every step), the co-rotational
// step (CorotationalFem::step_mm; naive: re-factorising every step) and the 1 kHz tick
// (ContactCompliance::contact_forces_n for 16 contact vertices, p50/p99 per call; naive: the
// full prefactored solve with those vertices prescribed). Medians of Google Benchmark
// repetitions. The FEM is single-threaded: Eigen runs without OpenMP, one core.

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <array>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <tuple>

#include "engine/errors.h"
#include "engine/fem/conforming_mesh.h"
#include "engine/fem/contact_compliance.h"
#include "engine/fem/corotational.h"
#include "engine/fem/linear_fem.h"
#include "engine/fem/tet_mesh.h"
#include "haptics/replay_summary.h"
#include "tools/bench.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

namespace fem = engine::fem;
using SparseMatrix = Eigen::SparseMatrix<double>;

struct FemBenchFlags {
  std::string sizes = "1000,5000,25000";
  std::string nakao_vertices = "243,319,463,512,873";
  bool spheres = true;
  double min_time_s = 0.2;
  int repetitions = 5;
  std::string csv, json;
};

// Nakao et al., "Adaptive proxy geometry for direct volume manipulation", Table 1: frames
// per second of deformation (linear FEM on the CPU) and volume rendering (GPU) together, on
// a Core2 Duo 3.0 GHz with a GeForce GTX 260.
struct NakaoRow {
  int vertices;
  const char* data;
  double fps;
};
constexpr std::array<NakaoRow, 5> kNakaoTable1 = {{{243, "Spheres", 27.6},
                                                   {319, "Engine", 21.8},
                                                   {463, "Kidney", 16.3},
                                                   {512, "Abdomen", 8.9},
                                                   {873, "Breast", 9.4}}};

constexpr double kSpacingMm = 4.0;
constexpr double kPoisson = 0.45;
constexpr double kBackgroundPa = 10e6;  // Nakao's background and red sphere
constexpr int kContactVertices = fem::ContactCompliance::kMaxVertices;
// Lateral traction (N/mm^2) on the top face: about 9 % shear strain at 10 MPa.
constexpr double kTopTractionMpa = 0.3;

// One mesh to measure, with its fixed side (z = 0), materials and loads.
struct FemCase {
  std::string kind;           // "lattice", "nakao", "spheres"
  int target = 0;             // tets (lattice, spheres) or vertices (nakao)
  std::array<int, 3> dims{};  // lattice vertices per axis; zeros for a conforming mesh
  std::string nakao_data;     // Nakao's row, for "nakao"
  double nakao_fps = NAN;
  double spacing_mm = kSpacingMm;  // lattice spacing, or the conforming mesh's coarse spacing
  int boundary_levels = 0;         // the conforming mesh's refinement at the spheres
  fem::TetMesh mesh;
  std::vector<fem::TetMaterial> materials;
  std::vector<int> fixed_dofs;
  std::function<fem::TetMesh()> build;  // how the conforming mesh is built (timed)
};

struct FemResult {
  int free_dofs = 0;
  double build_ms = NAN, factor_ms = NAN;
  double linear_hz = NAN, naive_cg_hz = NAN, naive_refactor_hz = NAN;
  int cg_iterations = 0;
  double cg_residual = NAN;
  double corot_hz = NAN, naive_corot_hz = NAN;
  std::string corot_mode;
  int contacts = 0;
  double tick_p50_us = NAN, tick_p99_us = NAN, naive_tick_p50_us = NAN, naive_tick_p99_us = NAN;
  double tick_force_error = NAN;  // max |f_ours - f_naive| / max |f_naive|
};

// The near-cubic lattice (vertices per axis n_x <= n_y <= n_z <= 2 n_x) whose count lies
// closest to `target`; ties go to the more cubic one.
std::array<int, 3> closest_lattice(double target,
                                   const std::function<double(int, int, int)>& count) {
  std::array<int, 3> best{2, 2, 2};
  double best_error = INFINITY;
  const int top = static_cast<int>(std::cbrt(target)) + 3;
  for (int x = 2; x <= top; ++x) {
    for (int y = x; y <= 2 * x; ++y) {
      for (int z = y; z <= 2 * x; ++z) {
        const double error = std::abs(count(x, y, z) - target);
        if (error < best_error || (error == best_error && z - x < best[2] - best[0])) {
          best = {x, y, z};
          best_error = error;
        }
      }
    }
  }
  return best;
}

int lattice_tets(const std::array<int, 3>& n) { return 6 * (n[0] - 1) * (n[1] - 1) * (n[2] - 1); }

// Every DOF of every vertex at the lowest z.
std::vector<int> bottom_dofs(const fem::TetMesh& mesh) {
  const double z0 = mesh.rest_mm.row(2).minCoeff();
  std::vector<int> vertices;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.rest_mm(2, v) <= z0 + 1e-9) vertices.push_back(v);
  }
  return fem::vertex_dofs(vertices);
}

FemCase lattice_case(const std::string& kind, int target, const std::array<int, 3>& dims) {
  FemCase c;
  c.kind = kind;
  c.target = target;
  c.dims = dims;
  c.mesh = fem::regular_lattice(dims, kSpacingMm, Eigen::Vector3d::Zero());
  c.materials.assign(c.mesh.tet_count(), {kBackgroundPa, kPoisson});
  c.fixed_dofs = bottom_dofs(c.mesh);
  return c;
}

// Four spheres on a regular tetrahedron around the centre of a 64 mm cube, laid out as the
// four-spheres generator does (radius 0.18 n, centres 0.3 n from the middle), with Nakao's
// moduli (Fig. 5): 100 MPa, 0.1 MPa, 10 MPa, 1 MPa; background 10 MPa.
FemCase spheres_case(int target_tets) {
  constexpr double kSideMm = 64.0, kMid = 32.0;
  const double radius = 0.18 * kSideMm, d = 0.3 * kSideMm / std::sqrt(3.0);
  const std::array<Eigen::Vector3d, 4> centres = {
      Eigen::Vector3d(kMid + d, kMid + d, kMid + d), Eigen::Vector3d(kMid + d, kMid - d, kMid - d),
      Eigen::Vector3d(kMid - d, kMid + d, kMid - d), Eigen::Vector3d(kMid - d, kMid - d, kMid + d)};
  const fem::LabelFunction label = [centres, radius](const Eigen::Vector3d& x) -> std::int32_t {
    for (int s = 0; s < 4; ++s) {
      if ((x - centres[s]).squaredNorm() < radius * radius) return s + 1;
    }
    return 0;
  };
  fem::ConformingMeshOptions options;
  options.box_mm = Eigen::AlignedBox3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(kSideMm));
  // The coarse spacing and boundary refinement that land nearest the target: a lattice
  // guess, then rescalings by the count each build gave; fewer boundary levels only when the
  // finer ones cannot come within 10 %. At most a quarter of the cube per cell: coarser
  // cells would miss the spheres.
  double best_spacing = 0;
  int best_error = INT_MAX, best_levels = 2;
  for (int levels = 2; levels >= 0 && best_error > target_tets / 10; --levels) {
    options.boundary_levels = levels;
    options.coarse_spacing_mm =
        std::clamp(std::cbrt(6.0 * std::pow(kSideMm, 3) / target_tets), 1.0, kSideMm / 4);
    for (int attempt = 0; attempt < 3; ++attempt) {
      const int tets = fem::build_conforming_mesh(options, label).mesh.tet_count();
      if (std::abs(tets - target_tets) < best_error) {
        best_error = std::abs(tets - target_tets);
        best_spacing = options.coarse_spacing_mm;
        best_levels = levels;
      }
      options.coarse_spacing_mm = std::clamp(
          options.coarse_spacing_mm * std::pow(double(tets) / target_tets, 0.4), 1.0, kSideMm / 4);
    }
  }
  options.coarse_spacing_mm = best_spacing;
  options.boundary_levels = best_levels;
  FemCase c;
  c.kind = "spheres";
  c.target = target_tets;
  c.spacing_mm = best_spacing;
  c.boundary_levels = best_levels;
  c.build = [options, label] { return fem::build_conforming_mesh(options, label).mesh; };
  c.mesh = c.build();
  const std::map<std::int32_t, fem::TetMaterial> by_label = {{0, {kBackgroundPa, kPoisson}},
                                                             {1, {100e6, kPoisson}},
                                                             {2, {0.1e6, kPoisson}},
                                                             {3, {10e6, kPoisson}},
                                                             {4, {1e6, kPoisson}}};
  c.materials = fem::materials_from_labels(c.mesh, by_label);
  c.fixed_dofs = bottom_dofs(c.mesh);
  return c;
}

// A lateral traction on the top face, shared equally by its vertices.
Eigen::VectorXd top_loads_n(const fem::TetMesh& mesh) {
  const double z1 = mesh.rest_mm.row(2).maxCoeff();
  const Eigen::Vector3d lo = mesh.rest_mm.rowwise().minCoeff(),
                        hi = mesh.rest_mm.rowwise().maxCoeff();
  const double area_mm2 = (hi.x() - lo.x()) * (hi.y() - lo.y());
  std::vector<int> top;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.rest_mm(2, v) >= z1 - 1e-9) top.push_back(v);
  }
  Eigen::VectorXd loads = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  for (int v : top) loads(fem::dof_index(v, 0)) = kTopTractionMpa * area_mm2 / top.size();
  return loads;
}

// The (up to) 16 wholly free vertices nearest the middle of the top face.
std::vector<int> contact_vertices(const fem::TetMesh& mesh, const fem::DofPartition& partition) {
  const Eigen::Vector3d lo = mesh.rest_mm.rowwise().minCoeff(),
                        hi = mesh.rest_mm.rowwise().maxCoeff();
  const Eigen::Vector3d top(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), hi.z());
  std::vector<std::pair<double, int>> by_distance;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    bool free = true;
    for (int i = 0; i < 3; ++i) free = free && partition.is_free(fem::dof_index(v, i));
    if (free) by_distance.emplace_back((mesh.rest_mm.col(v) - top).squaredNorm(), v);
  }
  std::sort(by_distance.begin(), by_distance.end());
  std::vector<int> vertices;
  for (int i = 0; i < std::min<int>(kContactVertices, by_distance.size()); ++i) {
    vertices.push_back(by_distance[i].second);
  }
  return vertices;
}

// Calls `fn` for at least `seconds` and `min_calls` calls, timing each; p50 and p99 (µs).
std::pair<double, double> per_call_us(double seconds, int min_calls,
                                      const std::function<void(int)>& fn) {
  using Clock = std::chrono::steady_clock;
  std::vector<double> us;
  const auto start = Clock::now();
  for (int i = 0; i < min_calls || Clock::now() - start < std::chrono::duration<double>(seconds);
       ++i) {
    const auto t0 = Clock::now();
    fn(i);
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  return {haptics::percentile(us, 50.0), haptics::percentile(us, 99.0)};
}

// The loads of step i: the base load, scaled by up to 15 % (new loads every step).
double load_scale(int i) { return 1.0 + 0.01 * (i & 15); }

FemResult measure_case(const FemCase& c, const FemBenchFlags& f) {
  FemResult r;
  std::vector<std::pair<std::string, BenchFn>> fns;
  if (c.build) {
    fns.emplace_back("build", [&c](benchmark::State& st) {
      for (auto _ : st) benchmark::DoNotOptimize(c.build().tet_count());
    });
  }
  fns.emplace_back("factor", [&c](benchmark::State& st) {
    for (auto _ : st) {
      const fem::LinearFem linear(c.mesh, c.materials, c.fixed_dofs);
      benchmark::DoNotOptimize(&linear);
    }
  });
  const fem::LinearFem linear(c.mesh, c.materials, c.fixed_dofs);
  const fem::DofPartition& partition = linear.partition();
  r.free_dofs = partition.free_count();
  const Eigen::VectorXd loads = top_loads_n(c.mesh);
  const Eigen::VectorXd none = Eigen::VectorXd::Zero(loads.size());
  SparseMatrix k_ff = linear.assembler().zero_matrix();
  linear.assembler().assemble(
      [&](int t) -> const fem::ElementMatrix& { return linear.element_stiffness(t); }, k_ff);
  const double tolerance = fem::CorotationalOptions{}.cg_relative_residual;
  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper, Eigen::IdentityPreconditioner>
      cg;
  cg.setTolerance(tolerance);
  cg.setMaxIterations(20 * r.free_dofs);
  cg.compute(k_ff);
  fns.emplace_back("linear", [&](benchmark::State& st) {
    int i = 0;
    for (auto _ : st)
      benchmark::DoNotOptimize(linear.solve_mm(load_scale(i++) * loads, none).data());
  });
  fns.emplace_back("naive-cg", [&](benchmark::State& st) {
    int i = 0;
    for (auto _ : st) {
      Eigen::VectorXd u = Eigen::VectorXd::Zero(loads.size());
      partition.add_free_part(cg.solve(partition.free_part(load_scale(i++) * loads)), u);
      benchmark::DoNotOptimize(u.data());
    }
  });
  fns.emplace_back("naive-refactor", [&](benchmark::State& st) {
    int i = 0;
    Eigen::SimplicialLDLT<SparseMatrix> ldlt;
    for (auto _ : st) {
      ldlt.compute(k_ff);
      Eigen::VectorXd u = Eigen::VectorXd::Zero(loads.size());
      partition.add_free_part(ldlt.solve(partition.free_part(load_scale(i++) * loads)), u);
      benchmark::DoNotOptimize(u.data());
    }
  });
  // Co-rotational steps from the loaded equilibrium, new loads every step, each step from
  // the last one's result (as the FEM thread runs it).
  fem::CorotationalFem corot(c.mesh, c.materials, c.fixed_dofs);
  fem::CorotationalOptions refactor_always;
  refactor_always.refactor_max_free_dofs = INT_MAX;
  fem::CorotationalFem naive_corot(c.mesh, c.materials, c.fixed_dofs, refactor_always);
  const Eigen::VectorXd equilibrium =
      corot.solve_mm(linear.solve_mm(loads, none), loads, none, 1e-6, 20);
  long cg_iterations = 0, steps = 0;
  auto corot_bench = [&](fem::CorotationalFem* model, bool count) {
    return [&, model, count](benchmark::State& st) {
      Eigen::VectorXd u = equilibrium;
      fem::CorotationalStepReport report;
      int i = 0;
      for (auto _ : st) {
        u = model->step_mm(u, load_scale(i++) * loads, none, &report);
        if (count) {
          cg_iterations += report.cg_iterations;
          ++steps;
        }
      }
      benchmark::DoNotOptimize(u.data());
    };
  };
  fns.emplace_back("corot", corot_bench(&corot, true));
  fns.emplace_back("naive-corot", corot_bench(&naive_corot, false));
  auto ns = measure(fns);
  auto hz = [&ns](const std::string& name) { return 1e9 / ns[name]; };
  if (c.build) r.build_ms = ns["build"] * 1e-6;
  r.factor_ms = ns["factor"] * 1e-6;
  r.linear_hz = hz("linear");
  r.naive_cg_hz = hz("naive-cg");
  r.naive_refactor_hz = hz("naive-refactor");
  r.corot_hz = hz("corot");
  r.naive_corot_hz = hz("naive-corot");
  r.corot_mode =
      r.free_dofs <= fem::CorotationalOptions{}.refactor_max_free_dofs
          ? "refactor"
          : "PCG " + std::to_string(steps ? (cg_iterations + steps / 2) / steps : 0) + " it";
  {
    const Eigen::VectorXd rhs = partition.free_part(loads);
    const Eigen::VectorXd x = cg.solve(rhs);
    r.cg_iterations = static_cast<int>(cg.iterations());
    r.cg_residual = (k_ff * x - rhs).norm() / rhs.norm();
  }

  // The tick: W^-1 u_c for 16 contact vertices pressed about half a millimetre, against the
  // full solve with those vertices prescribed (prefactored too, but over the whole mesh).
  const std::vector<int> contacts = contact_vertices(c.mesh, partition);
  r.contacts = static_cast<int>(contacts.size());
  const fem::ContactCompliance compliance(linear, contacts);
  std::vector<int> held = c.fixed_dofs;
  for (int dof : fem::vertex_dofs(contacts)) held.push_back(dof);
  const fem::LinearFem pinned(c.mesh, c.materials, held);
  const int m = 3 * r.contacts;
  std::vector<std::vector<double>> presses(64, std::vector<double>(m));
  for (int k = 0; k < 64; ++k) {
    for (int j = 0; j < m; ++j)
      presses[k][j] = j % 3 == 2 ? -0.5 - 0.002 * k : 0.01 * ((j + k) % 5);
  }
  std::vector<double> forces(m), naive_forces(m);
  auto naive_tick = [&](int i) {
    Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(loads.size());
    const std::vector<double>& press = presses[i & 63];
    for (int j = 0; j < m; ++j) prescribed(3 * contacts[j / 3] + j % 3) = press[j];
    const Eigen::VectorXd reactions = pinned.reactions_n(pinned.solve_mm(none, prescribed), none);
    for (int j = 0; j < m; ++j) naive_forces[j] = reactions(3 * contacts[j / 3] + j % 3);
  };
  const double seconds = f.min_time_s * f.repetitions;
  std::tie(r.tick_p50_us, r.tick_p99_us) = per_call_us(seconds, 1000, [&](int i) {
    compliance.contact_forces_n(presses[i & 63], forces);
    benchmark::DoNotOptimize(forces.data());
  });
  std::tie(r.naive_tick_p50_us, r.naive_tick_p99_us) = per_call_us(seconds, 20, naive_tick);
  compliance.contact_forces_n(presses[0], forces);
  naive_tick(0);
  double error = 0, scale = 0;
  for (int j = 0; j < m; ++j) {
    error = std::max(error, std::abs(forces[j] - naive_forces[j]));
    scale = std::max(scale, std::abs(naive_forces[j]));
  }
  r.tick_force_error = error / scale;
  return r;
}

// `v` printed with `format`, or "-" where there is no value.
std::string cell(const char* format, double v) {
  if (!std::isfinite(v)) return "-";
  char text[32];
  std::snprintf(text, sizeof text, format, v);
  return text;
}

std::string lattice_text(const FemCase& c) {
  if (c.dims[0] == 0) return "conf L" + std::to_string(c.boundary_levels);
  return std::to_string(c.dims[0]) + "x" + std::to_string(c.dims[1]) + "x" +
         std::to_string(c.dims[2]);
}

struct Goal {
  std::string what;
  double measured = NAN, goal = NAN;
  bool at_most = false;  // met when measured <= goal (a time), else when >= (a rate)
  std::string note;
  bool met() const { return at_most ? measured <= goal : measured >= goal; }
};

std::vector<Goal> goals(const std::vector<FemCase>& cases, const std::vector<FemResult>& results) {
  std::vector<Goal> out;
  double worst_p99 = -INFINITY;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const FemCase& c = cases[i];
    const FemResult& r = results[i];
    const std::string mesh = std::to_string(c.mesh.tet_count()) + " tets, " + lattice_text(c);
    if (c.kind == "lattice" && c.target == 1000) {
      out.push_back({"linear step >= 500 Hz at 1k tets", r.linear_hz, 500, false, mesh});
      out.push_back({"co-rotational step >= 100 Hz at 1k tets", r.corot_hz, 100, false,
                     mesh + ", " + r.corot_mode});
    }
    if (c.kind == "lattice" && c.target == 5000) {
      out.push_back({"linear step >= 100 Hz at 5k tets", r.linear_hz, 100, false, mesh});
    }
    if (c.kind == "nakao" && std::isfinite(c.nakao_fps)) {
      out.push_back({"beat Nakao Table 1 " + c.nakao_data + " (" + std::to_string(c.target) +
                         " vertices): " + json_number(c.nakao_fps) + " fps",
                     r.linear_hz, c.nakao_fps, false,
                     "ours: linear step Hz on " + std::to_string(c.mesh.vertex_count()) +
                         " vertices (" + lattice_text(c) +
                         "); Nakao: frames/s of deformation + GPU rendering"});
    }
    worst_p99 = std::max(worst_p99, r.tick_p99_us);
  }
  if (!results.empty()) {
    out.push_back({"tick p99 <= 20 us, 16 contact vertices", worst_p99, 20, true,
                   "worst p99 over all meshes"});
  }
  return out;
}

std::string csv_row_text(const FemCase& c, const FemResult& r) {
  std::ostringstream out;
  out << c.kind << "," << c.target << "," << c.dims[0] << "," << c.dims[1] << "," << c.dims[2]
      << "," << c.mesh.vertex_count() << "," << c.mesh.tet_count() << "," << r.free_dofs << ","
      << json_number(c.spacing_mm) << "," << json_number(r.build_ms) << ","
      << json_number(r.factor_ms) << "," << json_number(r.linear_hz) << ","
      << json_number(r.naive_cg_hz) << "," << r.cg_iterations << "," << json_number(r.cg_residual)
      << "," << json_number(r.naive_refactor_hz) << "," << json_number(r.corot_hz) << ","
      << r.corot_mode << "," << json_number(r.naive_corot_hz) << "," << r.contacts << ","
      << json_number(r.tick_p50_us) << "," << json_number(r.tick_p99_us) << ","
      << json_number(r.naive_tick_p50_us) << "," << json_number(r.naive_tick_p99_us) << ","
      << json_number(r.tick_force_error) << "," << c.nakao_data << "," << json_number(c.nakao_fps);
  return out.str();
}

constexpr const char* kCsvColumns =
    "kind,target,nx,ny,nz,vertices,tets,free_dofs,spacing_mm,build_ms,factor_ms,linear_hz,"
    "naive_cg_hz,naive_cg_iterations,naive_cg_residual,naive_refactor_hz,corot_hz,corot_mode,"
    "naive_corot_hz,contact_vertices,tick_p50_us,tick_p99_us,naive_tick_p50_us,"
    "naive_tick_p99_us,tick_force_rel_error,nakao_data,nakao_fps";

void write_outputs(const FemBenchFlags& f, const std::vector<FemCase>& cases,
                   const std::vector<FemResult>& results, const std::vector<Goal>& goal_rows) {
  const auto machine = machine_description();
  if (!f.csv.empty()) {
    std::string text = machine_csv_comments(machine) + kCsvColumns + "\n";
    for (std::size_t i = 0; i < cases.size(); ++i)
      text += csv_row_text(cases[i], results[i]) + "\n";
    write_atomically(f.csv, text);
    std::printf("\nwrote %s\n", f.csv.c_str());
  }
  if (!f.json.empty()) {
    std::ostringstream json;
    json << "{\n  \"machine\": " << machine_json(machine) << ",\n  \"rows\": [\n";
    std::vector<std::string> names;
    std::stringstream columns(kCsvColumns);
    for (std::string name; std::getline(columns, name, ',');) names.push_back(name);
    for (std::size_t i = 0; i < cases.size(); ++i) {
      std::stringstream values(csv_row_text(cases[i], results[i]));
      json << "    {";
      std::size_t k = 0;
      for (std::string value; std::getline(values, value, ','); ++k) {
        const bool text =
            names[k] == "kind" || names[k] == "corot_mode" || names[k] == "nakao_data";
        json << (k ? ", " : "") << json_string(names[k]) << ": "
             << (text ? json_string(value) : value);
      }
      json << "}" << (i + 1 < cases.size() ? "," : "") << "\n";
    }
    json << "  ],\n  \"goals\": [\n";
    for (std::size_t i = 0; i < goal_rows.size(); ++i) {
      const Goal& g = goal_rows[i];
      json << "    {\"goal\": " << json_string(g.what)
           << ", \"measured\": " << json_number(g.measured)
           << ", \"target\": " << json_number(g.goal)
           << ", \"met\": " << (g.met() ? "true" : "false") << ", \"note\": " << json_string(g.note)
           << "}" << (i + 1 < goal_rows.size() ? "," : "") << "\n";
    }
    json << "  ]\n}\n";
    write_atomically(f.json, json.str());
    std::printf("wrote %s\n", f.json.c_str());
  }
}

void run_bench_fem(const FemBenchFlags& f) {
  const std::vector<int> sizes = parse_int_list(f.sizes, "--sizes");
  std::vector<int> nakao;
  if (f.nakao_vertices != "none") nakao = parse_int_list(f.nakao_vertices, "--nakao-vertices");
  for (int v : nakao) {
    if (v < 8) throw InputError("--nakao-vertices", "at least 8 vertices");
  }
  if (!(f.min_time_s > 0.0)) throw InputError("--min-time-s", "must be positive");
  if (f.repetitions < 1) throw InputError("--repetitions", "must be at least 1");
  if (!f.csv.empty()) check_output_path(f.csv, "--csv");
  if (!f.json.empty()) check_output_path(f.json, "--json");
  init_benchmark(f.min_time_s, f.repetitions);

  std::vector<FemCase> cases;
  for (int tets : sizes) {
    cases.push_back(lattice_case("lattice", tets, closest_lattice(tets, [](int x, int y, int z) {
                                   return lattice_tets({x, y, z});
                                 })));
  }
  for (int vertices : nakao) {
    FemCase c = lattice_case("nakao", vertices, closest_lattice(vertices, [](int x, int y, int z) {
                               return static_cast<double>(x) * y * z;
                             }));
    for (const NakaoRow& row : kNakaoTable1) {
      if (row.vertices == vertices) {
        c.nakao_data = row.data;
        c.nakao_fps = row.fps;
      }
    }
    cases.push_back(std::move(c));
  }
  if (f.spheres) {
    for (int tets : sizes) cases.push_back(spheres_case(tets));
  }

  std::printf(
      "proxy-mesh FEM, single thread (Eigen %d thread%s, no OpenMP), median of %d "
      "repetitions of >= %g s\n",
      Eigen::nbThreads(), Eigen::nbThreads() == 1 ? "" : "s", f.repetitions, f.min_time_s);
  std::printf(
      "meshes: Kuhn lattices (6 tets per cube, %g mm, E %g MPa, nu %g) fixed at z = 0, "
      "a %g MPa lateral traction on the top face; spheres: conforming four-spheres mesh "
      "(64 mm cube, Nakao's moduli)\n",
      kSpacingMm, kBackgroundPa * 1e-6, kPoisson, kTopTractionMpa);
  std::printf(
      "naive: CG without preconditioner on K_FF to |r| <= %g |b| from zero; LDLT of "
      "K_FF every step; co-rotational step re-factorised every step; tick: the full "
      "prefactored solve with the contact vertices prescribed\n\n",
      fem::CorotationalOptions{}.cg_relative_residual);
  std::printf("%-8s %6s %10s %8s %7s %7s %9s %9s %10s %10s %6s %10s %8s %8s\n", "mesh", "target",
              "lattice", "vertices", "tets", "free", "build ms", "factor ms", "linear Hz", "CG Hz",
              "CG it", "refact Hz", "lin/CG", "lin/ref");
  std::vector<FemResult> results;
  for (const FemCase& c : cases) {
    const FemResult r = measure_case(c, f);
    std::printf("%-8s %6d %10s %8d %7d %7d %9s %9.3g %10.0f %10.1f %6d %10.1f %7.1fx %7.1fx\n",
                c.kind.c_str(), c.target, lattice_text(c).c_str(), c.mesh.vertex_count(),
                c.mesh.tet_count(), r.free_dofs, cell("%.3g", r.build_ms).c_str(), r.factor_ms,
                r.linear_hz, r.naive_cg_hz, r.cg_iterations, r.naive_refactor_hz,
                r.linear_hz / r.naive_cg_hz, r.linear_hz / r.naive_refactor_hz);
    std::fflush(stdout);
    results.push_back(r);
  }
  std::printf("\n%-8s %6s %7s %10s %-12s %10s %9s %9s %9s %9s %9s %9s %9s\n", "mesh", "target",
              "tets", "corot Hz", "corot mode", "naive Hz", "ours/nv", "tick p50", "tick p99",
              "naive p50", "naive p99", "p99 nv/us", "force err");
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const FemCase& c = cases[i];
    const FemResult& r = results[i];
    std::printf("%-8s %6d %7d %10.1f %-12s %10.1f %8.2fx %9.2f %9.2f %9.1f %9.1f %8.1fx %9.1e\n",
                c.kind.c_str(), c.target, c.mesh.tet_count(), r.corot_hz, r.corot_mode.c_str(),
                r.naive_corot_hz, r.corot_hz / r.naive_corot_hz, r.tick_p50_us, r.tick_p99_us,
                r.naive_tick_p50_us, r.naive_tick_p99_us, r.naive_tick_p99_us / r.tick_p99_us,
                r.tick_force_error);
  }
  std::printf(
      "(tick: %d contact vertices, us per call, timer included; force err: ours against "
      "the naive solve, relative)\n",
      results.empty() ? 0 : results.front().contacts);
  const std::vector<Goal> goal_rows = goals(cases, results);
  std::printf("\n%-58s %12s %10s %8s  %s\n", "goal", "measured", "goal", "met", "note");
  for (const Goal& g : goal_rows) {
    std::printf("%-58s %12.2f %10.2f %8s  %s\n", g.what.c_str(), g.measured, g.goal,
                g.met() ? "yes" : "NO", g.note.c_str());
  }
  write_outputs(f, cases, results, goal_rows);
}

}  // namespace

void add_bench_fem_command(CLI::App& bench) {
  auto flags = std::make_shared<FemBenchFlags>();
  CLI::App* cmd = bench.add_subcommand(
      "fem",
      "Proxy-mesh FEM: mesh build, factorisation, linear and co-rotational step rates and the "
      "1 kHz contact tick by tet count and at Nakao's Table 1 vertex counts, ours beside naive "
      "CG and re-factorisation, with the goals");
  cmd->add_option("--sizes", flags->sizes, "Tet counts (Kuhn lattices and conforming meshes)")
      ->capture_default_str();
  cmd->add_option("--nakao-vertices", flags->nakao_vertices,
                  "Vertex counts for Nakao's Table 1 rows (lattices), or 'none'")
      ->capture_default_str();
  cmd->add_flag("--spheres,!--no-spheres", flags->spheres,
                "Also the conforming four-spheres mesh at each tet count")
      ->capture_default_str();
  cmd->add_option("--min-time-s", flags->min_time_s, "Minimum time per measurement")
      ->capture_default_str();
  cmd->add_option("--repetitions", flags->repetitions, "Repetitions (the median is reported)")
      ->capture_default_str();
  cmd->add_option("--csv", flags->csv, "Write one row per mesh as CSV, with the machine");
  cmd->add_option("--json", flags->json, "Write the rows, goals and machine as JSON");
  cmd->callback([flags] { run_bench_fem(*flags); });
}

}  // namespace hapvox::cli
