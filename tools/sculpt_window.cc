#include "tools/sculpt_window.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <optional>
#include <thread>

#include "engine/errors.h"
#include "render/gl.h"
#include "render/pick.h"
#include "render/transfer_function.h"

namespace hapvox::cli {
namespace {

using Clock = std::chrono::steady_clock;
using Eigen::Vector3d;

std::string& glfw_error() {
  static std::string message;  // set by GLFW's error callback on whichever thread failed
  return message;
}

void on_glfw_error(int code, const char* description) {
  glfw_error() = std::string(description != nullptr ? description : "unknown") + " (" +
                 std::to_string(code) + ")";
}

// The pointer and keys, whoever moves them (GLFW's callbacks or the script), and what the
// tool does with them. Render thread only.
struct Input {
  double cursor_x = 0.0, cursor_y = 0.0;
  bool left_down = false;
  bool right_down = false;
  double right_x = 0.0, right_y = 0.0;  // the cursor when the right drag last moved
  bool dead_man = false;                // space held: the force ramps out
  double push_mm = 0.0;                 // along the view: + in
  double orbit_deg[2] = {0.0, 0.0};     // azimuth, elevation still to apply
  bool press_pending = false;           // a press to pick at the next frame
  bool end_requested = false;
  // A scripted move under way: from (x0, y0) at t0 to (x1, y1) at t1 (seconds).
  bool gliding = false;
  double glide[6] = {0, 0, 0, 0, 0, 0};

  void move(double x, double y) {
    if (right_down) {
      orbit_deg[0] -= 0.3 * (x - right_x);
      orbit_deg[1] += 0.3 * (y - right_y);
      right_x = x;
      right_y = y;
    }
    cursor_x = x;
    cursor_y = y;
  }
  void button(int which, bool down) {
    if (which == GLFW_MOUSE_BUTTON_LEFT) {
      if (down && !left_down) press_pending = true;
      left_down = down;
    } else if (which == GLFW_MOUSE_BUTTON_RIGHT) {
      right_down = down;
      right_x = cursor_x;
      right_y = cursor_y;
    }
  }
  void wheel(double steps, double step_mm) { push_mm += steps * step_mm; }
  void key(const std::string& name, bool down, double step_mm) {
    if (name == "space") dead_man = down;
    if (!down) return;
    if (name == "up") push_mm += step_mm;
    if (name == "down") push_mm -= step_mm;
    if (name == "left") orbit_deg[0] -= 5.0;
    if (name == "right") orbit_deg[0] += 5.0;
    if (name == "escape") end_requested = true;
  }
};

const char* key_name(int key) {
  switch (key) {
    case GLFW_KEY_SPACE:
      return "space";
    case GLFW_KEY_UP:
      return "up";
    case GLFW_KEY_DOWN:
      return "down";
    case GLFW_KEY_LEFT:
      return "left";
    case GLFW_KEY_RIGHT:
      return "right";
    case GLFW_KEY_ESCAPE:
      return "escape";
    default:
      return nullptr;
  }
}

struct Callbacks {
  Input* input;
  double step_mm;
};

Callbacks* callbacks_of(GLFWwindow* window) {
  return static_cast<Callbacks*>(glfwGetWindowUserPointer(window));
}

void install_callbacks(GLFWwindow* window) {
  glfwSetCursorPosCallback(
      window, [](GLFWwindow* w, double x, double y) { callbacks_of(w)->input->move(x, y); });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int) {
    callbacks_of(w)->input->button(button, action == GLFW_PRESS);
  });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    callbacks_of(w)->input->wheel(dy, callbacks_of(w)->step_mm);
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    const char* name = key_name(key);
    if (name == nullptr || action == GLFW_REPEAT) return;
    callbacks_of(w)->input->key(name, action == GLFW_PRESS, callbacks_of(w)->step_mm);
  });
}

// Applies the script's events due by `t_s`, up to the first press or release: each of
// those gets a frame of its own (a slow frame must not press and release at once, nor pick
// at a cursor that moved on). Adds the screenshots they ask for.
void play_script(const std::vector<haptics::PointerEvent>& script, std::size_t& next, double t_s,
                 Input& input, double step_mm, std::vector<std::string>& screenshots) {
  using K = haptics::PointerEvent::Kind;
  for (bool button = false; !button && next < script.size() && script[next].time_s <= t_s; ++next) {
    const haptics::PointerEvent& e = script[next];
    button = e.kind == K::kPress || e.kind == K::kRelease;
    switch (e.kind) {
      case K::kMove:
        if (e.over_s > 0.0) {
          input.gliding = true;
          const double g[6] = {input.cursor_x, input.cursor_y, e.time_s,
                               e.x_px,         e.y_px,         e.time_s + e.over_s};
          std::copy(g, g + 6, input.glide);
        } else {
          input.gliding = false;
          input.move(e.x_px, e.y_px);
        }
        break;
      case K::kPress:
        input.button(GLFW_MOUSE_BUTTON_LEFT, true);
        break;
      case K::kRelease:
        input.button(GLFW_MOUSE_BUTTON_LEFT, false);
        break;
      case K::kWheel:
        input.wheel(e.wheel_steps, step_mm);
        break;
      case K::kKeyDown:
        input.key(e.key, true, step_mm);
        break;
      case K::kKeyUp:
        input.key(e.key, false, step_mm);
        break;
      case K::kScreenshot:
        screenshots.push_back(e.path);
        break;
      case K::kQuit:
        input.end_requested = true;
        break;
    }
  }
  if (input.gliding) {
    const double* g = input.glide;
    const double f = std::clamp((t_s - g[2]) / (g[5] - g[2]), 0.0, 1.0);
    input.move(g[0] + f * (g[3] - g[0]), g[1] + f * (g[4] - g[1]));
    if (f >= 1.0) input.gliding = false;
  }
}

// A point (the renderer's frame) in window pixels; nullopt behind the eye.
std::optional<ImVec2> project(const render::OrbitCamera& camera, const Vector3d& p_mm, int width,
                              int height) {
  const Eigen::Vector4d eye = camera.view() * p_mm.homogeneous();
  const Eigen::Vector4d clip =
      camera.projection(static_cast<double>(width) / height, 1.0, 1e5) * eye;
  if (clip.w() <= 1e-9) return std::nullopt;
  const double x = clip.x() / clip.w(), y = clip.y() / clip.w();
  return ImVec2(static_cast<float>((x + 1.0) * 0.5 * width),
                static_cast<float>((1.0 - y) * 0.5 * height));
}

render::Image read_window(int width, int height) {
  render::Image image(width, height);
  std::vector<std::uint8_t> rows(image.rgba.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  const std::size_t stride = static_cast<std::size_t>(width) * 4;
  for (int y = 0; y < height; ++y) {  // GL's rows go bottom up
    std::copy_n(&rows[static_cast<std::size_t>(height - 1 - y) * stride], stride,
                image.pixel(0, y));
  }
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 255;
  return image;
}

}  // namespace

SculptWindow::SculptWindow(const engine::DensityField& field, const RenderSetup& setup,
                           haptics::MouseDevice& device, SculptWindowOptions options)
    : field_(field),
      // The background thread may write the field while the render thread starts: the
      // renderer is made from this copy, taken before any thread runs.
      field_copy_(std::make_unique<engine::DensityField>(field.grid().deepCopy(),
                                                         field.voxel_size_mm(), field.origin_mm(),
                                                         field.dims(), field.direction())),
      setup_(setup),
      device_(device),
      options_(std::move(options)) {
  // A window needs a display: say so now, before the session's files are made.
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    throw InputError("sculpt",
                     "no display (DISPLAY is not set): run it on a desktop, or "
                     "headless under xvfb-run");
  }
  glfwSetErrorCallback(on_glfw_error);
  if (glfwInit() != GLFW_TRUE) {
    throw InputError("sculpt",
                     "cannot open the display '" + std::string(display) + "': " + glfw_error());
  }
  glfwTerminate();
}

haptics::RenderLoop SculptWindow::loop() {
  return [this](haptics::RenderFeed& feed, haptics::RenderTiming& timing) {
    try {
      run(feed, timing);
    } catch (...) {
      device_.request_end();  // the force loop must not outlive its window
      throw;
    }
  };
}

void SculptWindow::run(haptics::RenderFeed& feed, haptics::RenderTiming& timing) {
  glfwSetErrorCallback(on_glfw_error);
  if (glfwInit() != GLFW_TRUE) throw render::RenderError("GLFW: " + glfw_error());
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  GLFWwindow* window =
      glfwCreateWindow(options_.width, options_.height, "hapvox sculpt", nullptr, nullptr);
  if (window == nullptr) {
    glfwTerminate();
    device_.request_end();
    throw render::RenderError("GLFW: cannot open a window with OpenGL 3.3: " + glfw_error());
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(0);  // paced below; a vsync wait would hold input back
  Input input;
  Callbacks callbacks{&input, options_.push_step_mm};
  glfwSetWindowUserPointer(window, &callbacks);
  install_callbacks(window);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini beside the user's files
  ImGui_ImplGlfw_InitForOpenGL(window, false);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  GLuint texture = 0;
  glGenTextures(1, &texture);
  // Closes everything in order however the loop ends (an error included); the renderer,
  // made below, goes first while the context is still current.
  struct Closer {
    GLFWwindow* window;
    GLuint* texture;
    ~Closer() {
      glDeleteTextures(1, texture);
      ImGui_ImplOpenGL3_Shutdown();
      ImGui_ImplGlfw_Shutdown();
      ImGui::DestroyContext();
      glfwDestroyWindow(window);
      glfwTerminate();
    }
  } closer{window, &texture};

  auto renderer = std::make_unique<render::VolumeRenderer>(
      *field_copy_, render::TransferFunction::from_spec(setup_.transfer_spec));
  render::OrbitCamera camera = render::OrbitCamera::framing(
      field_.grid_min_mm(), field_.grid_max_mm(), setup_.azimuth_deg, setup_.elevation_deg);
  render::RenderSettings settings = setup_.settings;
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);

  const double radius = options_.tool_radius_mm;
  const Eigen::Matrix3d to_grid = field_.direction().transpose();  // world -> grid vectors
  // The tool's target (the renderer's frame) and the drag plane's point.
  Vector3d target = field_.world_to_grid(device_.start_mm());
  Vector3d drag_point = target;
  bool dragging = false;
  std::size_t next_event = 0;
  std::vector<std::string> screenshots;
  const auto first_frame = Clock::now();
  const auto period = std::chrono::nanoseconds(std::llround(1e9 / options_.fps));
  auto next = first_frame;
  haptics::VoxelPatch patch;
  while (true) {
    const bool finishing = feed.done.load(std::memory_order_acquire);
    const auto begin = Clock::now();
    const double t_s = std::chrono::duration<double>(begin - first_frame).count();
    glfwPollEvents();
    play_script(options_.script, next_event, t_s, input, options_.push_step_mm, screenshots);
    if (glfwWindowShouldClose(window) || input.end_requested) device_.request_end();
    while (feed.voxels.pop(patch)) {
      renderer->set_voxel(patch.ijk, patch.density);
      ++timing.voxels_applied;
    }
    camera.azimuth_deg += input.orbit_deg[0];
    camera.elevation_deg = std::clamp(camera.elevation_deg + input.orbit_deg[1], -85.0, 85.0);
    input.orbit_deg[0] = input.orbit_deg[1] = 0.0;

    // The tool's target from the cursor: picking on what is drawn (Nakao §3.2).
    int window_w = 0, window_h = 0, frame_w = 0, frame_h = 0;
    glfwGetWindowSize(window, &window_w, &window_h);
    glfwGetFramebufferSize(window, &frame_w, &frame_h);
    window_w = std::max(window_w, 1), window_h = std::max(window_h, 1);
    frame_w = std::max(frame_w, 16), frame_h = std::max(frame_h, 16);
    const Vector3d eye = camera.eye_mm(), view = camera.view_direction();
    const Vector3d ray = camera.pixel_ray(static_cast<int>(input.cursor_x),
                                          static_cast<int>(input.cursor_y), window_w, window_h);
    const std::optional<Vector3d> hit =
        render::pick_surface(renderer->volume(), eye, ray, options_.surface_density);
    if (input.press_pending) {
      input.press_pending = false;
      ++report_.presses;
      if (!hit) ++report_.picks_missed;
      drag_point = hit ? *hit : target;  // nothing under the cursor: the tool's own depth
      input.push_mm = 0.0;
      dragging = true;
    }
    if (!input.left_down && dragging) {
      // The stroke ends: the tool lifts back out in front of the surface it was dragged on.
      dragging = false;
      // Along the view, far enough to clear a groove under an oblique view.
      target -= (3.0 * radius + 2.0 + std::max(0.0, input.push_mm)) * view;
      input.push_mm = 0.0;
    }
    if (dragging) {
      const double along = ray.dot(view);
      if (along > 1e-9) {
        const Vector3d on_plane = eye + ((drag_point - eye).dot(view) / along) * ray;
        target = on_plane + input.push_mm * view;
      }
    } else if (hit) {
      // Hovering just clear of the surface under the cursor, along its normal (along the
      // view where the density gives none).
      Vector3d out = render::surface_normal(renderer->volume(), *hit);
      if (out.isZero()) out = -view;
      target = *hit + (radius + 2.0 + std::max(0.0, -input.push_mm)) * out;
    }
    device_.set_target(field_.grid_to_world(target), input.dead_man);

    // The volume as the render thread's copy has it, the tool where the force thread put it.
    const haptics::RenderToolState tool = feed.tool.read();
    render::ToolPose pose;
    if (tool.tick >= 0) {
      pose.center_mm = field_.world_to_grid(tool.center_mm);
      pose.radius_mm = radius;
      pose.displacement_mm = to_grid * tool.displacement_mm;
      pose.in_contact = tool.in_contact;
    }
    settings.width = frame_w;
    settings.height = frame_h;
    const render::Image image = renderer->render(camera, pose, settings);
    glBindTexture(GL_TEXTURE_2D, texture);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, image.width, image.height, 0, GL_RGBA,
                 GL_UNSIGNED_BYTE, image.rgba.data());
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, frame_w, frame_h);
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);

    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const auto size = ImVec2(static_cast<float>(window_w), static_cast<float>(window_h));
    ImGui::GetBackgroundDrawList()->AddImage(
        reinterpret_cast<ImTextureID>(static_cast<std::intptr_t>(texture)), ImVec2(0, 0), size);
    // The force: an arrow from the tool's centre, and its magnitude beside the tip.
    const haptics::MouseFeedback felt = device_.feedback();
    const Vector3d force_world(felt.force_n[0], felt.force_n[1], felt.force_n[2]);
    const double force_n = force_world.norm();
    if (tool.tick >= 0 && force_n > 1e-3) {
      const Vector3d tip = pose.center_mm + options_.arrow_mm_per_n * (to_grid * force_world);
      const auto from = project(camera, pose.center_mm, window_w, window_h);
      const auto to = project(camera, tip, window_w, window_h);
      if (from && to) {
        ImDrawList* draw = ImGui::GetForegroundDrawList();
        const ImU32 colour = IM_COL32(255, 210, 40, 255);
        draw->AddLine(*from, *to, colour, 3.0f);
        const float dx = to->x - from->x, dy = to->y - from->y;
        const float length = std::max(1.0f, std::sqrt(dx * dx + dy * dy));
        const float ux = dx / length, uy = dy / length, head = std::min(12.0f, 0.5f * length);
        draw->AddTriangleFilled(
            *to, ImVec2(to->x - head * ux + 0.5f * head * uy, to->y - head * uy - 0.5f * head * ux),
            ImVec2(to->x - head * ux - 0.5f * head * uy, to->y - head * uy + 0.5f * head * ux),
            colour);
        char label[32];
        std::snprintf(label, sizeof label, "%.2f N", force_n);
        draw->AddText(ImVec2(to->x + 6.0f, to->y - 6.0f), colour, label);
      }
    }
    ImGui::SetNextWindowPos(ImVec2(8, 8));
    ImGui::SetNextWindowBgAlpha(0.6f);
    ImGui::Begin("hapvox", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                     ImGuiWindowFlags_NoInputs | ImGuiWindowFlags_NoSavedSettings);
    ImGui::Text("force  %.2f N  (ramp %.2f)%s", force_n, felt.force_scale,
                felt.released ? "  DEAD-MAN: force released" : "");
    ImGui::Text("loop   %.1f Hz  p99 lateness %.0f us  missed %llu  watchdog %llu",
                feed.loop.rate_hz.load(), feed.loop.p99_lateness_us.load(),
                static_cast<unsigned long long>(feed.loop.missed.load()),
                static_cast<unsigned long long>(feed.loop.watchdog_trips.load()));
    ImGui::Text("model  %s  tool %.1f mm  mass %lld units  %s", options_.model_label.c_str(),
                2.0 * radius, static_cast<long long>(feed.loop.total_mass_units.load()),
                felt.contact ? "contact" : "free");
    ImGui::Text("tool   %s  push %+.1f mm  tick %lld", dragging ? "dragging" : "hovering",
                input.push_mm, static_cast<long long>(felt.tick));
    ImGui::End();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (finishing && !options_.screenshot.empty()) screenshots.push_back(options_.screenshot);
    for (const std::string& path : screenshots) {
      render::write_png(read_window(frame_w, frame_h), path);
      report_.screenshots.push_back(path);
    }
    screenshots.clear();
    glfwSwapBuffers(window);
    ++report_.frames;
    timing.record_frame(feed.start, begin, tool.tick);
    if (finishing) break;
    next = std::max(next + period, Clock::now());
    while (Clock::now() < next && !feed.done.load(std::memory_order_acquire)) {
      std::this_thread::sleep_for(
          std::min<Clock::duration>(next - Clock::now(), std::chrono::milliseconds(2)));
    }
  }
}

}  // namespace hapvox::cli
