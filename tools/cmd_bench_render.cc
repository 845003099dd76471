// hapvox bench render: frames per second of the headless renderer at 256^2 and 512^2,
// ours (adaptive FFD slice mesh, empty-space cut) beside the naive mesh of the seed (500
// slices x 20 x 20 patches, every vertex displaced by Eq. 10) in the same run, and the
// image quality of both against a 500-slice reference (PSNR), with a tool pressing. Then the
// proxy-FEM model's rows: a lattice proxy mesh of about 3k vertices deformed by a smooth
// 6 mm grab, the volume resampled into the texture (render/proxy_resample.h, timed apart:
// it runs once per FEM step, not per frame) and drawn, against its 500-slice reference;
// beside it the block hybrid (render/tet_slicer.h: the deformed tets sliced, plain polygons
// elsewhere), and the cost of a new displacement plus a frame either way.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <tbb/global_control.h>

#include "engine/errors.h"
#include "engine/io/output_file.h"
#include "render/gl_context.h"
#include "render/proxy_resample.h"
#include "render/tet_slicer.h"
#include "render/volume_renderer.h"
#include "tools/bench.h"
#include "tools/cli.h"

namespace hapvox::cli {
namespace {

struct BenchRenderFlags {
  std::string volumes = "four-spheres:dims=256,data/engine_256x256x128_uint8.nrrd";
  std::string sizes = "256,512";
  int slices = 256;
  int frames = 9;
  std::string csv;
};

struct RenderBenchRow {
  std::string volume, method;
  int size = 0;
  double fps = 0, frame_ms = 0, draw_ms = 0;
  std::size_t vertices = 0;
  double psnr_db = 0;
};

// The proxy mesh the FEM rows deform: the Kuhn lattice of 14^3 vertices (2,744; 13,182 tets)
// over the volume's voxel-centre box (its cubes stretched to the box), displaced by a
// grab-like bump: vertices near the visible material's top centre move up to 6 mm up and
// sideways, fading smoothly (a Wendland C2 falloff over a quarter of the box's diagonal).
engine::fem::TetMesh bench_mesh(const engine::DensityField& field) {
  constexpr int kVertices = 14;
  const Eigen::Vector3d lo = field.index_to_world(Eigen::Vector3d::Zero());
  const Eigen::Vector3d hi = field.index_to_world(field.dims().cast<double>().array() - 1.0);
  engine::fem::TetMesh mesh =
      engine::fem::regular_lattice({kVertices, kVertices, kVertices}, 1.0, Eigen::Vector3d::Zero());
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    mesh.rest_mm.col(v) = lo + (mesh.rest_mm.col(v) / (kVertices - 1.0)).cwiseProduct(hi - lo);
  }
  return mesh;
}

Eigen::VectorXd bench_grab(const engine::fem::TetMesh& mesh, const Eigen::Vector3d& at_mm,
                           double support_mm) {
  Eigen::VectorXd u = Eigen::VectorXd::Zero(3 * mesh.vertex_count());
  const Eigen::Vector3d pull(4.0, 0.0, 4.5);  // |pull| = 6 mm
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const double q = (mesh.rest_mm.col(v) - at_mm).norm() / support_mm;
    if (q < 1.0) u.segment<3>(3 * v) = std::pow(1.0 - q, 4) * (4.0 * q + 1.0) * pull;
  }
  return u;
}

// Times f.frames frames of one renderer and settings (median, after a warm-up frame that
// sizes buffers and compiles shaders), scores the last against the reference, prints the row.
RenderBenchRow measure_row(render::VolumeRenderer& renderer, const render::OrbitCamera& camera,
                           const render::ToolPose& tool, const render::RenderSettings& settings,
                           const render::Image& reference, int frames, const std::string& volume,
                           const std::string& method) {
  std::vector<double> frame_ms, draw_ms;
  render::Image image;
  render::FrameStats stats;
  renderer.render(camera, tool, settings);
  for (int i = 0; i < frames; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    image = renderer.render(camera, tool, settings, &stats);
    frame_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    draw_ms.push_back(stats.draw_ms);
  }
  RenderBenchRow row;
  row.volume = volume;
  row.method = method;
  row.size = settings.width;
  row.frame_ms = haptics::percentile(frame_ms, 50.0);
  row.fps = 1000.0 / row.frame_ms;
  row.draw_ms = haptics::percentile(draw_ms, 50.0);
  row.vertices = stats.vertices;
  row.psnr_db = render::psnr_db(image, reference);
  std::printf("%-40s %5d %-30s %8.2f %9.1f %9.1f %9zu %8.1f\n", row.volume.c_str(), row.size,
              method.c_str(), row.fps, row.frame_ms, row.draw_ms, row.vertices, row.psnr_db);
  std::fflush(stdout);
  return row;
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, ',')) {
    // A generator spec has its own commas: "four-spheres:dims=256" stays whole, and a
    // "key=value" piece belongs to the spec before it.
    if (!parts.empty() && part.find('=') != std::string::npos &&
        part.find(':') == std::string::npos && parts.back().find(':') != std::string::npos) {
      parts.back() += "," + part;
    } else {
      parts.push_back(part);
    }
  }
  return parts;
}

void run_bench_render(const BenchRenderFlags& f) {
  if (f.frames < 1 || f.frames > 1000) throw InputError("--frames", "must lie in [1, 1000]");
  if (f.slices < 1 || f.slices > 4096) throw InputError("--slices", "must lie in [1, 4096]");
  std::vector<int> sizes;
  for (const std::string& s : split_list(f.sizes)) {
    char* end = nullptr;
    const long v = std::strtol(s.c_str(), &end, 10);
    if (*end != '\0' || v < 16 || v > 4096) {
      throw InputError("--sizes", "expected sizes in [16, 4096], got '" + s + "'");
    }
    sizes.push_back(static_cast<int>(v));
  }
  if (!f.csv.empty()) check_output_path(f.csv, "--csv");
  render::GlContext context;
  std::printf("headless rendering: %s, OpenGL %s\n", context.renderer().c_str(),
              context.version().c_str());
  std::printf("median of %d frames (mesh + upload + draw + read back), tool pressing 3 mm\n\n",
              f.frames);
  std::printf("%-40s %5s %-30s %8s %9s %9s %9s %8s\n", "volume", "size", "method", "fps",
              "frame ms", "draw ms", "vertices", "PSNR dB");
  std::vector<RenderBenchRow> rows;
  for (const std::string& spec : split_list(f.volumes)) {
    // The bundled volume is found wherever hapvox runs from (the default names it).
    const std::string path = find_bundled(spec);
    const engine::DensityField field = engine::load_volume(path, engine::IntensityMapping{});
    const bool generated = path.find(':') != std::string::npos;
    render::VolumeRenderer renderer(
        field, render::TransferFunction::from_spec(generated ? "ct-soft" : "ct-bone"));
    const render::OrbitCamera camera =
        render::OrbitCamera::framing(field.world_min_mm(), field.world_max_mm(), 30.0, 25.0);
    // The tool 3 mm into the material below the top-centre of the visible box.
    render::ToolPose tool;
    tool.radius_mm = 8.0 * field.voxel_size_mm().minCoeff();
    const Eigen::Vector3d top(0.5 * (renderer.visible_lo_mm().x() + renderer.visible_hi_mm().x()),
                              0.5 * (renderer.visible_lo_mm().y() + renderer.visible_hi_mm().y()),
                              renderer.visible_hi_mm().z());
    tool.center_mm = top + Eigen::Vector3d(0, 0, tool.radius_mm - 3.0);
    tool.displacement_mm = Eigen::Vector3d(0, 0, -3.0);
    tool.in_contact = true;
    // Our settings at one image size: f.slices slices, the adaptive mesh.
    const auto ours_at = [&](int size) {
      render::RenderSettings ours;
      ours.width = ours.height = size;
      ours.mesh.slices = f.slices;
      ours.mesh.voxel_mm = field.voxel_size_mm().minCoeff();
      return ours;
    };
    for (int size : sizes) {
      render::RenderSettings ours = ours_at(size);
      render::RenderSettings back_to_front = ours;  // every fragment shaded, the design before
      back_to_front.early_termination = false;
      render::RenderSettings naive = back_to_front;  // the seed's: back to front
      naive.mesh.slices = 500;
      naive.mesh.tessellation = render::Tessellation::kUniform;
      naive.mesh.patches = 20;
      naive.mesh.kernel = render::FfdKernel::kPaper;
      // Reference: 500 slices, our kernel, finely tessellated where it deforms.
      render::RenderSettings reference = back_to_front;
      reference.mesh.slices = 500;
      reference.ffd_error_px = 0.0;  // R / 8 cells
      const render::Image ref = renderer.render(camera, tool, reference);
      for (const auto& [method, settings] :
           {std::pair<std::string, render::RenderSettings>{"ours, back to front, no early end",
                                                           back_to_front},
            {"ours: adaptive, " + std::to_string(f.slices) + " slices", ours},
            {"naive: 500 x 20x20, Eq. 10", naive}}) {
        rows.push_back(measure_row(renderer, camera, tool, settings, ref, f.frames, spec, method));
      }
      const RenderBenchRow& a = rows[rows.size() - 2];
      const RenderBenchRow& b = rows.back();
      std::printf("%-40s %5d %-30s %7.1fx\n", "", size, "ours / naive", a.fps / b.fps);
    }
    // The proxy-FEM model: the same slices over the resampled texture, no FFD.
    render::VolumeRenderer deformed(
        field, render::TransferFunction::from_spec(generated ? "ct-soft" : "ct-bone"));
    render::ProxyResampler resampler(render::dense_copy(field));
    const engine::fem::TetMesh mesh = bench_mesh(field);
    resampler.set_mesh(mesh);
    const Eigen::VectorXd u =
        bench_grab(mesh, top, 0.25 * (field.world_max_mm() - field.world_min_mm()).norm());
    std::vector<double> resample_ms, serial_ms;
    render::ResampleStats resampled;
    for (int i = 0; i < 3; ++i) {  // the texture at rest, then deformed (timed)
      resampler.update(Eigen::VectorXd::Zero(u.size()));
      resampled = resampler.update(u);
      resample_ms.push_back(resampled.ms);
    }
    {  // the baseline: the same resample on one thread
      tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
      for (int i = 0; i < 3; ++i) {
        resampler.update(Eigen::VectorXd::Zero(u.size()));
        serial_ms.push_back(resampler.update(u).ms);
      }
    }
    // Shadows: the whole volume on the first shadowed frame, then only the columns the
    // resample changed.
    render::RenderSettings shadowed;
    shadowed.width = shadowed.height = 64;
    shadowed.shadows.enabled = true;
    render::FrameStats shadow_stats;
    deformed.render(camera, render::ToolPose{}, shadowed, &shadow_stats);
    const double shadow_full_ms = shadow_stats.shadow_ms;
    deformed.replace_texels(resampler.texels(), resampler.changed_bricks());
    deformed.render(camera, render::ToolPose{}, shadowed, &shadow_stats);
    std::printf("%-40s %5s %-30s shadow volume in %.1f ms whole, %.1f ms after the grab\n",
                spec.c_str(), "", "fem: shadows", shadow_full_ms, shadow_stats.shadow_ms);
    const Eigen::Vector3i bricks = render::brick_counts(field.dims());
    std::printf(
        "%-40s %5s %-30s resampled in %.1f ms (median of 3; %.1f ms on one thread, %.2fx), "
        "%zu of %d tets moved, %zu of %d bricks changed\n",
        spec.c_str(), "", "fem: proxy mesh 14^3", haptics::percentile(resample_ms, 50.0),
        haptics::percentile(serial_ms, 50.0),
        haptics::percentile(serial_ms, 50.0) / haptics::percentile(resample_ms, 50.0),
        resampled.moved_tets, mesh.tet_count(), resampled.changed_bricks, bricks.prod());
    // The block hybrid (render/tet_slicer.h): the rest texture, the moved tets' blocks sliced.
    render::VolumeRenderer hybrid(
        field, render::TransferFunction::from_spec(generated ? "ct-soft" : "ct-bone"));
    render::TetSlicer slicer(field.world_min_mm(), field.world_max_mm(), field.dims());
    slicer.set_mesh(mesh);
    std::vector<double> prepare_ms;
    render::TetSliceStats sliced;
    for (int i = 0; i < 3; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      sliced = slicer.set_displacement(u, field.voxel_size_mm().minCoeff() / 512.0);
      prepare_ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    hybrid.set_slice_builder(
        [&slicer](const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& view,
                  int slices, render::SliceMesh& out) { slicer.build(lo, hi, view, slices, out); });
    std::printf(
        "%-40s %5s %-30s prepared in %.1f ms (median of 3): %zu moved tets, %zu of %d "
        "blocks of 32^3 deformed, %zu tets sliced each frame\n",
        spec.c_str(), "", "fem: block hybrid", haptics::percentile(prepare_ms, 50.0),
        sliced.moved_tets, sliced.deformed_blocks, ((field.dims().array() + 31) / 32).prod(),
        sliced.sliced_tets);
    render::ToolPose grab;  // drawn where it holds the material, without the FFD's press
    grab.radius_mm = tool.radius_mm;
    grab.center_mm = top + Eigen::Vector3d(4.0, 0.0, 4.5);
    for (int size : sizes) {
      render::RenderSettings ours = ours_at(size);
      render::RenderSettings reference = ours;
      reference.early_termination = false;  // the reference sums every slice
      reference.mesh.slices = 500;
      const render::Image ref = deformed.render(camera, grab, reference);
      const RenderBenchRow row =
          measure_row(deformed, camera, grab, ours, ref, f.frames, spec,
                      "fem: resampled, " + std::to_string(f.slices) + " slices");
      // Against the voxel model's row at this size ("ours"), in the same run.
      const auto voxel = std::find_if(rows.begin(), rows.end(), [&](const RenderBenchRow& r) {
        return r.volume == spec && r.size == size && r.method.rfind("ours", 0) == 0;
      });
      std::printf("%-40s %5d %-30s %7.0f%%\n", "", size, "fem / voxel fps",
                  100.0 * row.fps / voxel->fps);
      std::fflush(stdout);
      rows.push_back(row);
      const RenderBenchRow slices_row =
          measure_row(hybrid, camera, grab, ours, ref, f.frames, spec,
                      "fem: block hybrid, " + std::to_string(f.slices) + " sl");
      rows.push_back(slices_row);
      // A new displacement every frame (the realtime case): the resample or the hybrid's
      // preparation, then a frame.
      const double resample_frame_ms = haptics::percentile(resample_ms, 50.0) + row.frame_ms;
      const double hybrid_frame_ms = haptics::percentile(prepare_ms, 50.0) + slices_row.frame_ms;
      std::printf("%-40s %5d %-30s resampled %.1f ms, block hybrid %.1f ms (%.2fx)\n", "", size,
                  "fem: new displacement + frame", resample_frame_ms, hybrid_frame_ms,
                  resample_frame_ms / hybrid_frame_ms);
      reference.shadows.enabled = ours.shadows.enabled = true;
      rows.push_back(measure_row(deformed, camera, grab, ours,
                                 deformed.render(camera, grab, reference), f.frames, spec,
                                 "fem + shadows"));
    }
  }
  std::printf(
      "\ngoals (DESIGN.md, CPU-only): >= 30 fps at 256^2, >= 15 fps at 512^2, PSNR >= 35 dB "
      "against the 500-slice reference; seed: 15 fps on a GPU; the FEM's frames >= 80%% of "
      "the voxel model's fps\n");
  if (!f.csv.empty()) {
    std::ostringstream out;
    out << "volume,size,method,fps,frame_ms,draw_ms,vertices,psnr_db\n";
    for (const RenderBenchRow& r : rows) {
      out << '"' << r.volume << "\"," << r.size << ",\"" << r.method << "\"," << r.fps << ','
          << r.frame_ms << ',' << r.draw_ms << ',' << r.vertices << ',' << r.psnr_db << '\n';
    }
    engine::io::write_text_atomically(f.csv, out.str());
  }
}

}  // namespace

void add_bench_render_command(CLI::App& bench) {
  auto flags = std::make_shared<BenchRenderFlags>();
  CLI::App* cmd = bench.add_subcommand(
      "render",
      "Headless rendering fps at 256^2 and 512^2: ours vs the seed's naive mesh, the FEM's "
      "resampled volume, PSNR");
  cmd->add_option("--volumes", flags->volumes, "Volumes (files or generators), comma-separated")
      ->capture_default_str();
  cmd->add_option("--sizes", flags->sizes, "Square image sizes, pixels")->capture_default_str();
  cmd->add_option("--slices", flags->slices, "Our slice count")->capture_default_str();
  cmd->add_option("--frames", flags->frames, "Frames per measurement (the median is reported)")
      ->capture_default_str();
  cmd->add_option("--csv", flags->csv, "Also write the table as CSV");
  cmd->callback([flags] { run_bench_render(*flags); });
}

}  // namespace hapvox::cli
