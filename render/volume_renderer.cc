#include "render/volume_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "engine/check.h"
#include "render/gl.h"
#include "render/gl_context.h"
#include "render/gl_program.h"

namespace hapvox::render {
namespace {

const char* const kSliceVertexShader = R"(#version 330 core
layout(location = 0) in vec3 position_mm;
layout(location = 1) in vec3 rest_mm;
layout(location = 2) in vec3 weight_gradient;
uniform mat4 mvp;
uniform vec3 volume_lo_mm;
uniform vec3 volume_size_mm;
out vec3 tex;
out vec3 grad_w;
void main() {
  tex = (rest_mm - volume_lo_mm) / volume_size_mm;
  grad_w = weight_gradient;
  gl_Position = mvp * vec4(position_mm, 1.0);
}
)";

// Premultiplied output, for "over" (back to front) or "under" (front to back) blending. The
// transfer function's opacity is per voxel of path: alpha' = 1 - (1 - alpha)^(slice spacing / voxel
// size).
const char* const kSliceFragmentShader = R"(#version 330 core
#extension GL_ARB_shader_image_load_store : enable
#ifdef GL_ARB_shader_image_load_store
// Depth test before the shader runs, even though it may discard: slices never write depth,
// and a fragment behind an opaque pixel (render/front_to_back.h) is then never shaded.
layout(early_fragment_tests) in;
#endif
in vec3 tex;
in vec3 grad_w;
out vec4 color;
uniform vec3 displacement_mm;
uniform sampler3D volume;
uniform sampler1D transfer;
uniform float alpha_exponent;
uniform float min_density;
uniform vec3 light_dir;
uniform vec3 half_dir;
uniform sampler3D shadow;
uniform float shadow_weight;
void main() {
  if (any(lessThan(tex, vec3(0.0))) || any(greaterThan(tex, vec3(1.0)))) discard;
  vec4 v = texture(volume, tex);
  if (v.a <= min_density) discard;
  vec4 c = texture(transfer, v.a);
  if (c.a <= 0.0) discard;
  float alpha = 1.0 - pow(1.0 - c.a, alpha_exponent);
  vec3 g = v.rgb * 2.0 - 1.0;
  float g_len = length(g);
  // The light from above that reaches here (render/shadow_volume.h); exactly 1 unshadowed.
  float lit = 1.0 - shadow_weight * (1.0 - texture(shadow, tex).r);
  vec3 rgb = c.rgb * lit;
  if (g_len > 0.25) {
    // The FFD's inverse-transpose Jacobian turns the rest normal into the deformed one.
    vec3 n = g - grad_w * dot(displacement_mm, g) / (1.0 + dot(grad_w, displacement_mm));
    n = normalize(n);
    float diffuse = abs(dot(n, light_dir));
    float specular = pow(abs(dot(n, half_dir)), 24.0);
    rgb = c.rgb * (0.35 + 0.65 * diffuse) * lit + vec3(0.25 * specular * lit);
  }
  color = vec4(min(rgb, vec3(1.0)) * alpha, alpha);
}
)";

const char* const kToolVertexShader = R"(#version 330 core
layout(location = 0) in vec3 unit;
uniform mat4 mvp;
uniform vec3 center_mm;
uniform float radius_mm;
out vec3 normal;
void main() {
  normal = unit;
  gl_Position = mvp * vec4(center_mm + radius_mm * unit, 1.0);
}
)";

const char* const kToolFragmentShader = R"(#version 330 core
in vec3 normal;
out vec4 color;
uniform vec3 light_dir;
uniform vec3 tool_rgb;
void main() {
  float diffuse = max(dot(normalize(normal), -light_dir), 0.0);
  color = vec4(tool_rgb * (0.3 + 0.7 * diffuse), 1.0);
}
)";

void set_matrix(GLuint program, const char* name, const Eigen::Matrix4d& m) {
  const Eigen::Matrix4f f = m.cast<float>();  // column-major, as GL expects
  glUniformMatrix4fv(glGetUniformLocation(program, name), 1, GL_FALSE, f.data());
}
void set_vec3(GLuint program, const char* name, const Eigen::Vector3d& v) {
  glUniform3f(glGetUniformLocation(program, name), static_cast<float>(v.x()),
              static_cast<float>(v.y()), static_cast<float>(v.z()));
}

// Slices drawn between two saturation masks (render/front_to_back.h): each mask costs a
// copy of the colour buffer and a full-screen pass.
constexpr int kSlicesPerMask = 16;

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

struct VolumeRenderer::Gl {
  GLuint volume_texture = 0, transfer_texture = 0;
  GLuint shadow_texture = 0, unlit_texture = 0;  // transmittance, and 1x1x1 "fully lit"
  GLuint slice_program = 0, tool_program = 0;
  GLuint slice_vao = 0, slice_vbo = 0, slice_ibo = 0;
  GLuint tool_vao = 0, tool_vbo = 0, tool_ibo = 0;
  GLsizei tool_index_count = 0;
  GLuint framebuffer = 0, color_buffer = 0, depth_buffer = 0;
  int fb_width = 0, fb_height = 0;
  std::size_t slice_vbo_bytes = 0, slice_ibo_bytes = 0;

  ~Gl() {
    glDeleteTextures(1, &volume_texture);
    glDeleteTextures(1, &transfer_texture);
    glDeleteTextures(1, &shadow_texture);
    glDeleteTextures(1, &unlit_texture);
    glDeleteProgram(slice_program);
    glDeleteProgram(tool_program);
    glDeleteVertexArrays(1, &slice_vao);
    glDeleteBuffers(1, &slice_vbo);
    glDeleteBuffers(1, &slice_ibo);
    glDeleteVertexArrays(1, &tool_vao);
    glDeleteBuffers(1, &tool_vbo);
    glDeleteBuffers(1, &tool_ibo);
    glDeleteFramebuffers(1, &framebuffer);
    glDeleteRenderbuffers(1, &color_buffer);
    glDeleteRenderbuffers(1, &depth_buffer);
  }
};

VolumeRenderer::VolumeRenderer(const engine::DensityField& field, const TransferFunction& transfer)
    : gl_(std::make_unique<Gl>()), volume_(dense_copy(field)) {
  HAPVOX_CHECK(volume_.dims.minCoeff() > 0);
  const Eigen::Vector3i& dims = volume_.dims;
  texels_.assign(volume_.voxel_count() * 4, 0);
  bricks_ = brick_counts(dims);
  dirty_.assign(static_cast<std::size_t>(bricks_.prod()), 0);
  compute_texels(Eigen::Vector3i::Zero(), dims);

  Gl& g = *gl_;
  glGenTextures(1, &g.volume_texture);
  glBindTexture(GL_TEXTURE_3D, g.volume_texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage3D(GL_TEXTURE_3D, 0, GL_RGBA8, dims.x(), dims.y(), dims.z(), 0, GL_RGBA,
               GL_UNSIGNED_BYTE, texels_.data());
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) {
    glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
  }
  glGenTextures(1, &g.transfer_texture);
  set_transfer_function(transfer);
  const std::uint8_t fully_lit = 255;
  glGenTextures(1, &g.unlit_texture);
  glBindTexture(GL_TEXTURE_3D, g.unlit_texture);
  glTexImage3D(GL_TEXTURE_3D, 0, GL_R8, 1, 1, 1, 0, GL_RED, GL_UNSIGNED_BYTE, &fully_lit);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);

  g.slice_program = link_program(kSliceVertexShader, kSliceFragmentShader);
  g.tool_program = link_program(kToolVertexShader, kToolFragmentShader);
  saturation_ = std::make_unique<SaturationMask>();

  glGenVertexArrays(1, &g.slice_vao);
  glBindVertexArray(g.slice_vao);
  glGenBuffers(1, &g.slice_vbo);
  glGenBuffers(1, &g.slice_ibo);
  glBindBuffer(GL_ARRAY_BUFFER, g.slice_vbo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.slice_ibo);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(SliceVertex),
                        reinterpret_cast<void*>(offsetof(SliceVertex, position)));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(SliceVertex),
                        reinterpret_cast<void*>(offsetof(SliceVertex, rest)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, sizeof(SliceVertex),
                        reinterpret_cast<void*>(offsetof(SliceVertex, weight_gradient)));

  // A unit UV sphere for the tool.
  std::vector<float> sphere;
  std::vector<std::uint32_t> sphere_indices;
  const int rings = 16, segments = 32;
  for (int i = 0; i <= rings; ++i) {
    const double theta = M_PI * i / rings;
    for (int j = 0; j <= segments; ++j) {
      const double phi = 2.0 * M_PI * j / segments;
      sphere.insert(sphere.end(), {static_cast<float>(std::sin(theta) * std::cos(phi)),
                                   static_cast<float>(std::sin(theta) * std::sin(phi)),
                                   static_cast<float>(std::cos(theta))});
    }
  }
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      const std::uint32_t a = i * (segments + 1) + j, b = a + segments + 1;
      sphere_indices.insert(sphere_indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  }
  glGenVertexArrays(1, &g.tool_vao);
  glBindVertexArray(g.tool_vao);
  glGenBuffers(1, &g.tool_vbo);
  glGenBuffers(1, &g.tool_ibo);
  glBindBuffer(GL_ARRAY_BUFFER, g.tool_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(sphere.size() * sizeof(float)),
               sphere.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.tool_ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(sphere_indices.size() * sizeof(std::uint32_t)),
               sphere_indices.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  g.tool_index_count = static_cast<GLsizei>(sphere_indices.size());
  glBindVertexArray(0);
  check_gl("creating the renderer");
}

VolumeRenderer::~VolumeRenderer() = default;

void VolumeRenderer::compute_texels(const Eigen::Vector3i& lo, const Eigen::Vector3i& hi) {
  for (int z = lo.z(); z < hi.z(); ++z) {
    for (int y = lo.y(); y < hi.y(); ++y) {
      for (int x = lo.x(); x < hi.x(); ++x) {
        const float rho = volume_.density[volume_.index(x, y, z)];
        encode_texel(central_gradient(volume_, x, y, z), rho, &texels_[volume_.index(x, y, z) * 4]);
        if (rho > 0.0f) grow_visible(x, y, z);
      }
    }
  }
}

void VolumeRenderer::grow_visible(int x, int y, int z) {
  // The box only grows: material that left a place may still be drawn there.
  const Eigen::Vector3d lo_mm =
      volume_.lo_mm + Eigen::Vector3d(x, y, z).cwiseProduct(volume_.voxel_mm);
  const Eigen::Vector3d hi_mm = lo_mm + volume_.voxel_mm;
  if (has_visible_) {
    visible_lo_ = visible_lo_.cwiseMin(lo_mm);
    visible_hi_ = visible_hi_.cwiseMax(hi_mm);
  } else {
    visible_lo_ = lo_mm;
    visible_hi_ = hi_mm;
    has_visible_ = true;
  }
}

void VolumeRenderer::set_voxel(const openvdb::Coord& ijk, float density) {
  const Eigen::Vector3i& dims = volume_.dims;
  if (ijk.x() < 0 || ijk.y() < 0 || ijk.z() < 0 || ijk.x() >= dims.x() || ijk.y() >= dims.y() ||
      ijk.z() >= dims.z()) {
    return;  // outside the rendered box
  }
  volume_.density[volume_.index(ijk.x(), ijk.y(), ijk.z())] = std::clamp(density, 0.0f, 1.0f);
  // The gradient of a voxel's neighbours changes too: mark every brick within one voxel.
  for (int dz = -1; dz <= 1; ++dz) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int bx = (ijk.x() + dx) / kBrickVoxels, by = (ijk.y() + dy) / kBrickVoxels,
                  bz = (ijk.z() + dz) / kBrickVoxels;
        if (ijk.x() + dx < 0 || ijk.y() + dy < 0 || ijk.z() + dz < 0 || bx >= bricks_.x() ||
            by >= bricks_.y() || bz >= bricks_.z()) {
          continue;
        }
        const auto b = static_cast<std::uint32_t>((bz * bricks_.y() + by) * bricks_.x() + bx);
        if (!dirty_[b]) {
          dirty_[b] = 1;
          dirty_list_.push_back(b);
        }
      }
    }
  }
}

std::size_t VolumeRenderer::flush_changes() {
  for (std::uint32_t b : dirty_list_) {
    dirty_[b] = 0;
    Eigen::Vector3i lo, hi;
    brick_voxel_box(volume_.dims, b, lo, hi);
    compute_texels(lo, hi);
  }
  upload_bricks(dirty_list_, "uploading changed bricks");
  const std::size_t n = dirty_list_.size();
  dirty_list_.clear();
  return n;
}

std::size_t VolumeRenderer::replace_texels(const std::vector<std::uint8_t>& texels,
                                           const std::vector<std::uint32_t>& bricks) {
  HAPVOX_CHECK_EQ(texels.size(), texels_.size());
  for (std::uint32_t b : bricks) {
    Eigen::Vector3i lo, hi;
    brick_voxel_box(volume_.dims, b, lo, hi);
    for (int z = lo.z(); z < hi.z(); ++z) {
      for (int y = lo.y(); y < hi.y(); ++y) {
        for (int x = lo.x(); x < hi.x(); ++x) {
          const std::size_t i = volume_.index(x, y, z) * 4;
          std::copy_n(&texels[i], 4, &texels_[i]);
          if (texels_[i + 3] > 0) grow_visible(x, y, z);
        }
      }
    }
  }
  upload_bricks(bricks, "uploading replaced bricks");
  return bricks.size();
}

namespace {

// Uploads the 8^3 bricks `bricks` of `voxels` (the whole box, `format` bytes per voxel:
// GL_RGBA or GL_RED) into `texture`, brick by brick.
void upload_brick_boxes(GLuint texture, const Eigen::Vector3i& dims,
                        const std::vector<std::uint32_t>& bricks, GLenum format,
                        const std::uint8_t* voxels) {
  glBindTexture(GL_TEXTURE_3D, texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, dims.x());
  glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, dims.y());
  for (std::uint32_t b : bricks) {
    Eigen::Vector3i lo, hi;
    brick_voxel_box(dims, b, lo, hi);
    glPixelStorei(GL_UNPACK_SKIP_PIXELS, lo.x());
    glPixelStorei(GL_UNPACK_SKIP_ROWS, lo.y());
    glPixelStorei(GL_UNPACK_SKIP_IMAGES, lo.z());
    glTexSubImage3D(GL_TEXTURE_3D, 0, lo.x(), lo.y(), lo.z(), hi.x() - lo.x(), hi.y() - lo.y(),
                    hi.z() - lo.z(), format, GL_UNSIGNED_BYTE, voxels);
  }
  for (GLenum p : {GL_UNPACK_ROW_LENGTH, GL_UNPACK_IMAGE_HEIGHT, GL_UNPACK_SKIP_PIXELS,
                   GL_UNPACK_SKIP_ROWS, GL_UNPACK_SKIP_IMAGES}) {
    glPixelStorei(p, 0);
  }
}

}  // namespace

void VolumeRenderer::upload_bricks(const std::vector<std::uint32_t>& bricks, const char* what) {
  if (bricks.empty()) return;
  upload_brick_boxes(gl_->volume_texture, volume_.dims, bricks, GL_RGBA, texels_.data());
  bricks_uploaded_total_ += bricks.size();
  if (shadow_) shadow_->mark_bricks(bricks);
  check_gl(what);
}

void VolumeRenderer::update_shadows(int blur_voxels) {
  Gl& g = *gl_;
  const Eigen::Vector3i& dims = volume_.dims;
  if (!shadow_ || shadow_->blur_voxels() != blur_voxels) {  // the first frame with shadows
    shadow_ = std::make_unique<ShadowVolume>(dims, blur_voxels);
    if (g.shadow_texture == 0) {
      glGenTextures(1, &g.shadow_texture);
      glBindTexture(GL_TEXTURE_3D, g.shadow_texture);
      glTexImage3D(GL_TEXTURE_3D, 0, GL_R8, dims.x(), dims.y(), dims.z(), 0, GL_RED,
                   GL_UNSIGNED_BYTE, nullptr);
      glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) {
        glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
      }
    }
  }
  const std::vector<std::uint32_t>& changed = shadow_->update(texels_, opacity_);
  if (changed.empty()) return;
  upload_brick_boxes(g.shadow_texture, dims, changed, GL_RED, shadow_->transmittance().data());
  check_gl("uploading the shadow volume");
}

void VolumeRenderer::set_transfer_function(const TransferFunction& transfer) {
  first_visible_density_ = transfer.first_visible_density();
  for (int i = 0; i < TransferFunction::kSize; ++i) opacity_[i] = transfer.entry(i)[3];
  if (shadow_) shadow_->mark_all();
  std::vector<float> table(TransferFunction::kSize * 4);
  for (int i = 0; i < TransferFunction::kSize; ++i) {
    for (int c = 0; c < 4; ++c) table[i * 4 + c] = transfer.entry(i)[c];
  }
  glBindTexture(GL_TEXTURE_1D, gl_->transfer_texture);
  glTexImage1D(GL_TEXTURE_1D, 0, GL_RGBA32F, TransferFunction::kSize, 0, GL_RGBA, GL_FLOAT,
               table.data());
  glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_1D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  check_gl("uploading the transfer function");
}

void VolumeRenderer::ensure_framebuffer(int width, int height) {
  Gl& g = *gl_;
  if (g.framebuffer != 0 && g.fb_width == width && g.fb_height == height) return;
  if (g.framebuffer == 0) {
    glGenFramebuffers(1, &g.framebuffer);
    glGenRenderbuffers(1, &g.color_buffer);
    glGenRenderbuffers(1, &g.depth_buffer);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, g.framebuffer);
  glBindRenderbuffer(GL_RENDERBUFFER, g.color_buffer);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g.color_buffer);
  glBindRenderbuffer(GL_RENDERBUFFER, g.depth_buffer);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g.depth_buffer);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw RenderError("OpenGL: the offscreen framebuffer is incomplete");
  }
  g.fb_width = width;
  g.fb_height = height;
}

Image VolumeRenderer::render(const OrbitCamera& camera, const ToolPose& tool,
                             const RenderSettings& settings, FrameStats* stats) {
  HAPVOX_CHECK_GT(settings.width, 0);
  HAPVOX_CHECK_GT(settings.height, 0);
  Gl& g = *gl_;
  FrameStats frame;
  frame.bricks_uploaded = flush_changes();
  if (settings.shadows.enabled) {
    const auto ts = std::chrono::steady_clock::now();
    update_shadows(settings.shadows.blur_voxels);
    frame.shadow_ms = ms_since(ts);
  }

  // Slices cover the visible material, grown by how far the FFD can move it.
  // Slices are cut in rest space (the FFD then moves their vertices wherever the press
  // takes them) to the visible material plus one voxel, so the cut never clips the
  // trilinear fringe at the material's faces.
  const Eigen::Vector3d lo = visible_lo_ - volume_.voxel_mm;
  const Eigen::Vector3d hi = visible_hi_ + volume_.voxel_mm;
  const Eigen::Vector3d view_dir = camera.view_direction();
  auto tm = std::chrono::steady_clock::now();
  if (has_visible_ && (hi - lo).minCoeff() > 0.0) {
    if (slice_builder_) {
      slice_builder_(lo, hi, view_dir, settings.mesh.slices, mesh_);
    } else {
      SliceMeshOptions mesh_options = settings.mesh;
      if (settings.ffd_error_px > 0.0 && mesh_options.max_error_mm <= 0.0) {
        // One pixel's size at the tool's distance from the eye.
        const double pixel_mm = 2.0 * (camera.eye_mm() - tool.center_mm).norm() *
                                std::tan(0.5 * camera.fov_y_deg * M_PI / 180.0) / settings.height;
        mesh_options.max_error_mm = settings.ffd_error_px * pixel_mm;
      }
      build_slice_mesh(volume_.lo_mm, volume_.hi_mm, lo, hi, view_dir, tool, mesh_options, mesh_);
    }
  } else {
    mesh_.vertices.clear();
    mesh_.indices.clear();
    mesh_.slice_first_index.clear();
  }
  frame.mesh_ms = ms_since(tm);
  frame.vertices = mesh_.vertices.size();
  frame.triangles = mesh_.indices.size() / 3;

  // Front to back the background goes under everything at the end (composite_background).
  const bool front_to_back = settings.early_termination && mesh_.slice_first_index.size() >= 2;
  if (front_to_back) {
    order_front_to_back(mesh_, kSlicesPerMask, front_to_back_indices_, chunk_ends_);
  }
  const std::vector<std::uint32_t>& indices =
      front_to_back ? front_to_back_indices_ : mesh_.indices;

  ensure_framebuffer(settings.width, settings.height);
  glBindFramebuffer(GL_FRAMEBUFFER, g.framebuffer);
  glViewport(0, 0, settings.width, settings.height);
  if (front_to_back) {
    glClearColor(0.0f, 0.0f, 0.0f, 0.0f);
  } else {
    glClearColor(settings.background[0], settings.background[1], settings.background[2], 1.0f);
  }
  glClearDepth(1.0);
  glDepthMask(GL_TRUE);  // a clear honours the write mask the last frame's slices left off
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  // Near and far planes from the volume's bounding sphere.
  const Eigen::Vector3d centre = 0.5 * (volume_.lo_mm + volume_.hi_mm);
  const double reach = tool.in_contact ? tool.displacement_mm.norm() : 0.0;
  const double radius = 0.5 * (volume_.hi_mm - volume_.lo_mm).norm() + reach + tool.radius_mm;
  const double eye_distance = (camera.eye_mm() - centre).norm();
  const double near_mm = std::max(0.01 * radius, eye_distance - radius);
  const double far_mm = eye_distance + radius;
  const Eigen::Matrix4d mvp =
      camera.projection(static_cast<double>(settings.width) / settings.height, near_mm, far_mm) *
      camera.view();
  const Eigen::Vector3d light = -view_dir;  // headlight
  const Eigen::Vector3d half_dir = light;   // eye and light coincide

  // The tool is opaque. Back to front it is drawn first and the slices blend over it; front
  // to back its depth goes first (slices behind it fail the test) and its colour last,
  // under the slices in front of it.
  const bool draw_tool = settings.draw_tool && tool.radius_mm > 0.0;
  const auto draw_tool_pass = [&](bool colour) {
    glEnable(GL_DEPTH_TEST);
    glColorMask(colour, colour, colour, colour);
    glUseProgram(g.tool_program);
    set_matrix(g.tool_program, "mvp", mvp);
    set_vec3(g.tool_program, "center_mm", tool.center_mm);
    glUniform1f(glGetUniformLocation(g.tool_program, "radius_mm"),
                static_cast<float>(tool.radius_mm));
    set_vec3(g.tool_program, "light_dir", view_dir);
    set_vec3(g.tool_program, "tool_rgb", Eigen::Vector3d(0.45, 0.6, 0.85));
    glBindVertexArray(g.tool_vao);
    glDrawElements(GL_TRIANGLES, g.tool_index_count, GL_UNSIGNED_INT, nullptr);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  };
  glDepthFunc(GL_LESS);
  if (draw_tool) {
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    draw_tool_pass(!front_to_back);
  }

  auto tu = std::chrono::steady_clock::now();
  glBindVertexArray(g.slice_vao);
  const std::size_t vbytes = mesh_.vertices.size() * sizeof(SliceVertex);
  const std::size_t ibytes = indices.size() * sizeof(std::uint32_t);
  glBindBuffer(GL_ARRAY_BUFFER, g.slice_vbo);
  if (vbytes > g.slice_vbo_bytes) {
    g.slice_vbo_bytes = vbytes;
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vbytes), nullptr, GL_STREAM_DRAW);
  }
  glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(vbytes), mesh_.vertices.data());
  if (ibytes > g.slice_ibo_bytes) {
    g.slice_ibo_bytes = ibytes;
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(ibytes), nullptr, GL_STREAM_DRAW);
  }
  glBufferSubData(GL_ELEMENT_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(ibytes), indices.data());
  frame.upload_ms = ms_since(tu);

  auto td = std::chrono::steady_clock::now();
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_FALSE);  // slices are blended, never hide each other
  glEnable(GL_BLEND);
  if (front_to_back) {
    glBlendFunc(GL_ONE_MINUS_DST_ALPHA, GL_ONE);  // under
  } else {
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // over
  }
  glUseProgram(g.slice_program);
  set_matrix(g.slice_program, "mvp", mvp);
  set_vec3(g.slice_program, "volume_lo_mm", volume_.lo_mm);
  set_vec3(g.slice_program, "volume_size_mm", volume_.hi_mm - volume_.lo_mm);
  set_vec3(g.slice_program, "light_dir", light);
  set_vec3(g.slice_program, "half_dir", half_dir);
  set_vec3(g.slice_program, "displacement_mm",
           tool.in_contact ? tool.displacement_mm : Eigen::Vector3d::Zero());
  glUniform1f(glGetUniformLocation(g.slice_program, "alpha_exponent"),
              static_cast<float>(mesh_.slice_spacing_mm / volume_.voxel_mm.minCoeff()));
  glUniform1f(glGetUniformLocation(g.slice_program, "min_density"),
              std::max(0.0f, first_visible_density_));
  glUniform1i(glGetUniformLocation(g.slice_program, "volume"), 0);
  glUniform1i(glGetUniformLocation(g.slice_program, "transfer"), 1);
  glUniform1i(glGetUniformLocation(g.slice_program, "shadow"), 2);
  glUniform1f(glGetUniformLocation(g.slice_program, "shadow_weight"),
              settings.shadows.enabled ? static_cast<float>(settings.shadows.strength) : 0.0f);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_3D, g.volume_texture);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_1D, g.transfer_texture);
  glActiveTexture(GL_TEXTURE2);
  glBindTexture(GL_TEXTURE_3D, settings.shadows.enabled ? g.shadow_texture : g.unlit_texture);
  glActiveTexture(GL_TEXTURE0);
  if (front_to_back) {
    std::size_t begin = 0;
    for (std::size_t c = 0; c < chunk_ends_.size(); ++c) {
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(chunk_ends_[c] - begin), GL_UNSIGNED_INT,
                     reinterpret_cast<void*>(begin * sizeof(std::uint32_t)));
      begin = chunk_ends_[c];
      if (c + 1 < chunk_ends_.size()) saturation_->mark(settings.width, settings.height);
    }
    if (draw_tool) {
      glDepthFunc(GL_LEQUAL);  // its own depth, written by its first pass
      draw_tool_pass(true);
      glDepthFunc(GL_LESS);
    }
  } else {
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(indices.size()), GL_UNSIGNED_INT, nullptr);
  }
  glFinish();
  frame.draw_ms = ms_since(td);

  auto tr = std::chrono::steady_clock::now();
  Image image(settings.width, settings.height);
  std::vector<std::uint8_t> rows(image.rgba.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, settings.width, settings.height, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  const std::size_t stride = static_cast<std::size_t>(settings.width) * 4;
  for (int y = 0; y < settings.height; ++y) {  // GL's first row is the bottom one
    std::copy_n(&rows[(settings.height - 1 - y) * stride], stride, image.pixel(0, y));
  }
  if (front_to_back) composite_background(settings.background, image);
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 255;
  frame.read_ms = ms_since(tr);
  check_gl("rendering a frame");
  if (stats != nullptr) *stats = frame;
  return image;
}

}  // namespace hapvox::render
