#pragma once
// Draws a density field with view-aligned slices of an FFD slice mesh (render/slice_mesh.h),
// front to back with early termination (render/front_to_back.h), into an offscreen
// framebuffer: a 3D texture holds density and its
// precomputed gradient, a 1D texture the transfer function; Blinn-Phong shading from the
// gradient with a headlight, optionally darkened by volume shadows from a light above
// (render/shadow_volume.h); the tool drawn as a shaded sphere.
//
// Needs a current GlContext on the calling thread; every call must come from that thread.
// The renderer keeps its own dense copy of the field: changes arrive as voxel values
// (set_voxel, from whichever thread owns the field) and only the 8^3 bricks they touch are
// recomputed and re-uploaded (flush_changes), never the whole texture.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "engine/density_field.h"
#include "render/camera.h"
#include "render/front_to_back.h"
#include "render/image.h"
#include "render/shadow_volume.h"
#include "render/slice_mesh.h"
#include "render/texels.h"
#include "render/transfer_function.h"

namespace hapvox::render {

struct FrameStats {
  double mesh_ms = 0.0;    // building the slice mesh on the CPU
  double upload_ms = 0.0;  // vertex buffers and changed bricks
  double shadow_ms = 0.0;  // recomputing and uploading the shadow volume's changed columns
  double draw_ms = 0.0;    // GL draw until finished
  double read_ms = 0.0;    // reading the pixels back
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t bricks_uploaded = 0;
};

/// Volume shadows from a light above the volume (render/shadow_volume.h).
struct ShadowSettings {
  bool enabled = false;
  double strength = 0.6;  // the share of the shading a full shadow takes away, [0, 1]
  int blur_voxels = 2;    // the penumbra's half-width, [0, 8]
};

struct RenderSettings {
  int width = 512;
  int height = 512;
  SliceMeshOptions mesh;
  ShadowSettings shadows;
  bool draw_tool = true;
  float background[3] = {0.08f, 0.09f, 0.11f};
  /// Slices front to back, skipping pixels that are already opaque (render/front_to_back.h);
  /// false: back to front, every fragment shaded (the baseline `bench render` sets beside).
  bool early_termination = true;
  /// The FFD mesh near the tool is as coarse as keeps its displacement within this many
  /// pixels of the kernel's, at the tool (SliceMeshOptions::max_error_mm); 0: R / 8 cells.
  double ffd_error_px = 0.5;
};

class VolumeRenderer {
 public:
  /// Uploads `field` whole (the only full upload) and compiles the shaders.
  VolumeRenderer(const engine::DensityField& field, const TransferFunction& transfer);
  ~VolumeRenderer();
  VolumeRenderer(const VolumeRenderer&) = delete;
  VolumeRenderer& operator=(const VolumeRenderer&) = delete;

  /// Records a changed voxel (index space, density in [0, 1]); cheap, no GL.
  void set_voxel(const openvdb::Coord& ijk, float density);
  /// Recomputes and uploads the bricks changed since the last call. Returns how many.
  std::size_t flush_changes();

  /// Replaces the texels of `bricks` (indices x fastest over brick_counts(dims)) with those
  /// of `texels` (RGBA8, the whole box, render/texels.h) and uploads them: the proxy mesh's
  /// resampled volume (render/proxy_resample.h). Returns how many bricks. Voxels changed
  /// through set_voxel afterwards are recomputed from the density as before.
  std::size_t replace_texels(const std::vector<std::uint8_t>& texels,
                             const std::vector<std::uint32_t>& bricks);

  void set_transfer_function(const TransferFunction& transfer);

  /// Makes the slices each frame draws: the visible box [lo, hi] (mm), the view direction,
  /// the settings' slice count, into `mesh`.
  using SliceBuilder =
      std::function<void(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                         const Eigen::Vector3d& view_direction, int slices, SliceMesh& mesh)>;
  /// Slices from `builder` instead of the FFD slice mesh (the proxy mesh's block hybrid,
  /// render/tet_slicer.h); an empty function brings the FFD slices back.
  void set_slice_builder(SliceBuilder builder) { slice_builder_ = std::move(builder); }

  /// Renders one frame. Changes not yet flushed are flushed first.
  Image render(const OrbitCamera& camera, const ToolPose& tool, const RenderSettings& settings,
               FrameStats* stats = nullptr);

  /// The box of visible material (world mm), the part of the volume the slices cover.
  const Eigen::Vector3d& visible_lo_mm() const { return visible_lo_; }
  const Eigen::Vector3d& visible_hi_mm() const { return visible_hi_; }
  const Eigen::Vector3d& volume_lo_mm() const { return volume_.lo_mm; }
  const Eigen::Vector3d& volume_hi_mm() const { return volume_.hi_mm; }
  std::uint64_t bricks_uploaded() const { return bricks_uploaded_total_; }
  /// The renderer's own copy of the density, as set_voxel changed it (picking reads it:
  /// render/pick.h).
  const DenseVolume& volume() const { return volume_; }

 private:
  struct Gl;
  void compute_texels(const Eigen::Vector3i& lo, const Eigen::Vector3i& hi);
  void grow_visible(int x, int y, int z);
  void upload_bricks(const std::vector<std::uint32_t>& bricks, const char* what);
  void ensure_framebuffer(int width, int height);
  void update_shadows(int blur_voxels);

  std::unique_ptr<Gl> gl_;
  std::unique_ptr<SaturationMask> saturation_;
  std::vector<std::uint32_t> front_to_back_indices_;  // this frame's slices, nearest first
  std::vector<std::size_t> chunk_ends_;               // where each masked run of slices ends
  SliceBuilder slice_builder_;
  DenseVolume volume_;
  Eigen::Vector3d visible_lo_ = Eigen::Vector3d::Zero(), visible_hi_ = Eigen::Vector3d::Zero();
  bool has_visible_ = false;
  float first_visible_density_ = 0.0f;
  std::vector<std::uint8_t> texels_;  // RGBA8 (render/texels.h), volume_'s layout
  std::vector<std::uint8_t> dirty_;   // one flag per 8^3 brick
  std::vector<std::uint32_t> dirty_list_;
  Eigen::Vector3i bricks_;
  std::uint64_t bricks_uploaded_total_ = 0;
  SliceMesh mesh_;
  std::array<float, TransferFunction::kSize> opacity_{};  // the transfer function's, per entry
  std::unique_ptr<ShadowVolume> shadow_;                  // made by the first shadowed frame
};

}  // namespace hapvox::render
