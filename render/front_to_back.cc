#include "render/front_to_back.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "engine/check.h"
#include "render/gl.h"
#include "render/gl_context.h"
#include "render/gl_program.h"

namespace hapvox::render {
namespace {

// One triangle covering the viewport at the near plane (window depth 0).
const char* const kMaskVertexShader = R"(#version 330 core
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) * 4) - 1.0, float((gl_VertexID >> 1) * 4) - 1.0);
  gl_Position = vec4(p, -1.0, 1.0);
}
)";

// Keeps the pixels whose accumulated alpha is 1; their depth 0 then hides every later
// slice fragment there.
const char* const kMaskFragmentShader = R"(#version 330 core
uniform sampler2D accumulated;
out vec4 color;
void main() {
  if (texelFetch(accumulated, ivec2(gl_FragCoord.xy), 0).a < 1.0) discard;
  color = vec4(0.0);
}
)";

}  // namespace

void order_front_to_back(const SliceMesh& mesh, int chunk_slices,
                         std::vector<std::uint32_t>& indices,
                         std::vector<std::size_t>& chunk_ends) {
  HAPVOX_CHECK_GT(chunk_slices, 0);
  const std::vector<std::uint32_t>& first = mesh.slice_first_index;
  HAPVOX_CHECK_GE(first.size(), 2u);
  HAPVOX_CHECK_EQ(first.back(), mesh.indices.size());
  indices.clear();
  chunk_ends.clear();
  const std::size_t slices = first.size() - 1;
  for (std::size_t k = 0; k < slices; ++k) {
    const std::size_t slice = slices - 1 - k;  // nearest first
    indices.insert(indices.end(), mesh.indices.begin() + first[slice],
                   mesh.indices.begin() + first[slice + 1]);
    if ((k + 1) % static_cast<std::size_t>(chunk_slices) == 0 || k + 1 == slices) {
      chunk_ends.push_back(indices.size());
    }
  }
}

// The background under what front to back left: C + (1 - A) background, in the
// framebuffer's 8-bit steps.
void composite_background(const float (&background)[3], Image& image) {
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
    const int rest = 255 - image.rgba[i + 3];
    for (int c = 0; c < 3; ++c) {
      const int under = static_cast<int>(std::lround(rest * background[c]));
      image.rgba[i + c] = static_cast<std::uint8_t>(std::min(255, image.rgba[i + c] + under));
    }
  }
}

SaturationMask::SaturationMask() {
  program_ = link_program(kMaskVertexShader, kMaskFragmentShader);
  glGenVertexArrays(1, &vao_);  // core profile: a draw needs one, even without attributes
  glGenTextures(1, &copy_texture_);
}

SaturationMask::~SaturationMask() {
  glDeleteProgram(program_);
  glDeleteVertexArrays(1, &vao_);
  glDeleteTextures(1, &copy_texture_);
}

void SaturationMask::mark(int width, int height) {
  GLint active_texture = 0, program = 0, vao = 0;
  glGetIntegerv(GL_ACTIVE_TEXTURE, &active_texture);
  glGetIntegerv(GL_CURRENT_PROGRAM, &program);
  glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vao);
  glActiveTexture(GL_TEXTURE3);
  glBindTexture(GL_TEXTURE_2D, copy_texture_);
  if (width != width_ || height != height_) {
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    width_ = width;
    height_ = height;
  }
  // A copy: sampling the buffer being drawn into would be a feedback loop.
  glCopyTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, 0, 0, width, height);
  glUseProgram(program_);
  glUniform1i(glGetUniformLocation(program_, "accumulated"), 3);
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_ALWAYS);
  glBindVertexArray(vao_);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_FALSE);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glBindVertexArray(static_cast<GLuint>(vao));
  glUseProgram(static_cast<GLuint>(program));
  glActiveTexture(static_cast<GLenum>(active_texture));
}

}  // namespace hapvox::render
