#pragma once
// What `hapvox render` and `hapvox replay --render-dir` share: the rendering flags and a
// FrameRecorder that draws frames of a session to DIR/frame_NNNN.png, in lockstep (a frame
// every N ticks) or on a realtime render thread fed by haptics::RenderFeed.

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "engine/density_field.h"
#include "haptics/render_feed.h"
#include "render/gl_context.h"
#include "render/proxy_resample.h"
#include "render/volume_renderer.h"

namespace hapvox::cli {

/// The files a FrameRecorder writes into its directory (a regular expression on names).
inline constexpr const char* kFrameFileNames = "frame_[0-9]{4,}\\.png";

/// --transfer, --size, --slices, --tessellation, --patches, --kernel, --support-mm,
/// --azimuth-deg, --elevation-deg, --gradient, --shadows (with a prefix such as "render-" where a
/// command has flags of its own). "N" or "WxH" (16 to 8192 pixels each) into width and height;
/// InputError(flag, ...).
void parse_size(const std::string& text, const std::string& flag, int& width, int& height);

/// The transfer function a `--transfer` value names: "auto" is ct-bone for a volume file and
/// clay for a generator (what `hapvox render` and `--pick` draw with by default).
std::string transfer_spec_for(const std::string& transfer, const std::string& volume_spec);

struct RenderFlags {
  std::string transfer = "auto";
  std::string size = "512";
  int slices = 256;
  std::string tessellation = "adaptive";
  int patches = 20;
  std::string kernel = "wendland";
  double support_mm = 0.0;
  double azimuth_deg = 30.0;
  double elevation_deg = 25.0;
  std::string gradient = "rotation";  // the FEM model's shading (render/gradient_rotation.h)
  bool shadows = false;               // volume shadows from a light above (render/shadow_volume.h)
  void add_to(CLI::App& app, const std::string& prefix = "");
};

/// Checked settings; throws InputError naming the flag.
struct RenderSetup {
  render::RenderSettings settings;
  render::ResampleOptions resample;  // the FEM model's proxy-mesh resampling
  std::string transfer_spec;
  double azimuth_deg = 0, elevation_deg = 0;
};
RenderSetup resolve_render_flags(const RenderFlags& flags, const std::string& volume_spec,
                                 const engine::DensityField& field, const std::string& prefix = "");

class FrameRecorder {
 public:
  /// Creates `dir`, an EGL context current on this thread and a renderer of `field`. With
  /// `on_render_thread`, only checks that a context can be made: the render loop makes its
  /// own on the render thread, whose priority and CPU Mesa's rasteriser threads inherit.
  /// `field` must outlive the recorder and not change until the renderer is made.
  FrameRecorder(const engine::DensityField& field, const RenderSetup& setup, std::string dir,
                double tool_radius_mm, bool on_render_thread = false);
  /// Takes the context back to this thread to free the GL objects.
  ~FrameRecorder();
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  /// Renders the frame for this tool state and writes the next frame_NNNN.png.
  void draw(const haptics::RenderToolState& tool, const render::OrbitCamera* camera = nullptr);
  void set_voxel(const openvdb::Coord& ijk, float density) { renderer_->set_voxel(ijk, density); }

  /// The proxy-FEM model: frames show the volume as the proxy mesh deforms it, resampled into
  /// the renderer's texture (render/proxy_resample.h, the setup's gradient transform), and the
  /// tool at its place without the FFD's press. Call before the first frame.
  void use_proxy_mesh();
  /// The FEM's node displacements (mm, 3 per vertex of `mesh`, the run's `mesh_index`-th
  /// mesh: 0 its first), as the next frames show them; resampled now, on the calling thread
  /// (the render thread in realtime).
  void deform(const engine::fem::TetMesh& mesh, int mesh_index,
              const Eigen::Ref<const Eigen::VectorXd>& displacement_mm);
  /// Resampling work so far: updates and their total time.
  int resamples() const { return resamples_; }
  double resample_ms_total() const { return resample_ms_total_; }

  /// A render loop for a realtime session (a recorder made `on_render_thread`): makes the
  /// context and renderer, draws frames at `fps` until the feed is done, then a last one,
  /// and frees them again on that thread.
  haptics::RenderLoop realtime_loop(double fps);

  int frames() const { return frames_; }
  const RenderSetup& setup() const { return setup_; }
  double frame_ms_total() const { return frame_ms_total_; }
  const render::OrbitCamera& camera() const { return camera_; }
  const render::GlContext& context() const { return *context_; }

 private:
  render::Image render_now(const haptics::RenderToolState& tool, const render::OrbitCamera& camera,
                           render::FrameStats* stats);

  void make_renderer();

  const engine::DensityField& field_;
  RenderSetup setup_;
  std::string dir_;
  double tool_radius_mm_;
  render::RenderSettings settings_;
  bool on_render_thread_;
  render::OrbitCamera camera_;
  std::unique_ptr<render::GlContext> context_;
  std::unique_ptr<render::VolumeRenderer> renderer_;
  std::unique_ptr<render::ProxyResampler> resampler_;
  int mesh_index_ = -1;  // the mesh resampler_ deforms with
  int resamples_ = 0;
  double resample_ms_total_ = 0.0;
  int frames_ = 0;
  double frame_ms_total_ = 0.0;
};

}  // namespace hapvox::cli
