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

#include <tbb/task_arena.h>

#include "engine/errors.h"
#include "render/gl.h"
#include "render/pick.h"
#include "render/proxy_resample.h"
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
  std::optional<SegmentEnd> segment_key;  // [ ] p z m: what the next segment changes
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
    if (name == "[") segment_key = SegmentEnd::kSmallerTool;
    if (name == "]") segment_key = SegmentEnd::kLargerTool;
    if (name == "p") segment_key = SegmentEnd::kTogglePlastic;
    if (name == "z") segment_key = SegmentEnd::kUndo;
    if (name == "m") segment_key = SegmentEnd::kSwitchModel;
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
    case GLFW_KEY_LEFT_BRACKET:
      return "[";
    case GLFW_KEY_RIGHT_BRACKET:
      return "]";
    case GLFW_KEY_P:
      return "p";
    case GLFW_KEY_Z:
      return "z";
    case GLFW_KEY_M:
      return "m";
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

// Applies the script's events due by `t_s`, up to the first press, release or key down:
// each of those gets a frame of its own (a slow frame must not press and release at once,
// pick at a cursor that moved on, or see a key only once the next stroke has begun). Adds
// the screenshots they ask for.
void play_script(const std::vector<haptics::PointerEvent>& script, std::size_t& next, double t_s,
                 Input& input, double step_mm, std::vector<std::string>& screenshots) {
  using K = haptics::PointerEvent::Kind;
  for (bool own_frame = false; !own_frame && next < script.size() && script[next].time_s <= t_s;
       ++next) {
    const haptics::PointerEvent& e = script[next];
    own_frame = e.kind == K::kPress || e.kind == K::kRelease || e.kind == K::kKeyDown;
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

// The render thread's state that outlives a segment: the window, its context and overlay,
// the camera, the input and where the script is.
struct SculptWindow::Session {
  GLFWwindow* window = nullptr;
  GLuint texture = 0;
  Input input;
  Callbacks callbacks{&input, 0.5};
  std::unique_ptr<render::VolumeRenderer> renderer;  // this segment's volume
  // The FEM model's segments: the volume resampled from the proxy mesh's displacements.
  std::unique_ptr<render::ProxyResampler> resampler;
  render::OrbitCamera camera;
  Vector3d target = Vector3d::Zero();      // the tool's target, the renderer's frame
  Vector3d drag_point = Vector3d::Zero();  // a stroke's drag plane passes through it
  bool dragging = false;                   // a stroke is under way (left button held)
  std::size_t next_event = 0;              // the script's next
  // The script's clock: seconds of frames drawn, stopped between segments (a key's change
  // takes as long as it takes; the strokes after it keep their pace).
  double script_s = 0.0;
};

SculptWindow::SculptWindow(const engine::DensityField& frame, const RenderSetup& setup,
                           SculptWindowOptions options)
    : frame_(openvdb::FloatGrid::create(0.0f), frame.voxel_size_mm(), frame.origin_mm(),
             frame.dims(), frame.direction()),
      setup_(setup),
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

SculptWindow::~SculptWindow() { close(); }

haptics::RenderLoop SculptWindow::loop(const engine::DensityField& field,
                                       haptics::WatchedDevice& device, haptics::MouseDevice* mouse,
                                       SculptSegmentSetup setup) {
  // The background thread may write the field while the render thread starts: the
  // renderer is made from this copy, taken before any thread runs.
  field_copy_ =
      std::make_unique<engine::DensityField>(field.grid().deepCopy(), field.voxel_size_mm(),
                                             field.origin_mm(), field.dims(), field.direction());
  device_ = &device;
  mouse_ = mouse;
  segment_setup_ = std::move(setup);
  segment_ = SculptSegmentReport{};
  return [this](haptics::RenderFeed& feed, haptics::RenderTiming& timing) {
    try {
      run(feed, timing);
    } catch (...) {
      device_->request_end();  // the force loop must not outlive its window
      throw;
    }
  };
}

void SculptWindow::open() {
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
    throw render::RenderError("GLFW: cannot open a window with OpenGL 3.3: " + glfw_error());
  }
  auto session = std::make_unique<Session>();
  session->window = window;
  session->callbacks.step_mm = options_.push_step_mm;
  glfwMakeContextCurrent(window);
  glfwSwapInterval(0);  // paced below; a vsync wait would hold input back
  glfwSetWindowUserPointer(window, &session->callbacks);
  install_callbacks(window);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini beside the user's files
  ImGui_ImplGlfw_InitForOpenGL(window, false);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  glGenTextures(1, &session->texture);
  glBindTexture(GL_TEXTURE_2D, session->texture);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  session->camera = render::OrbitCamera::framing(frame_.grid_min_mm(), frame_.grid_max_mm(),
                                                 setup_.azimuth_deg, setup_.elevation_deg);
  session->target = mouse_ != nullptr ? frame_.world_to_grid(mouse_->start_mm())
                                      : 0.5 * (frame_.grid_min_mm() + frame_.grid_max_mm());
  session_ = std::move(session);
}

void SculptWindow::close() noexcept {
  if (!session_) return;
  Session& s = *session_;
  // The last segment's thread let the context go; this one takes it to free what it holds.
  glfwMakeContextCurrent(s.window);
  s.renderer.reset();
  glDeleteTextures(1, &s.texture);
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(s.window);
  glfwTerminate();
  session_.reset();
}

// The tool's target from the cursor (the mouse moves the tool). Picking on what is drawn
// (Nakao §3.2): a press starts a stroke on the view plane through the surface point under
// the cursor, which the drag then follows (pushed in or out along the view by the wheel);
// between strokes the tool hovers over the surface under the cursor, clear of the material.
void SculptWindow::steer_tool(int window_w, int window_h, std::int64_t felt_tick) {
  Session& s = *session_;
  Input& input = s.input;
  const double radius = segment_setup_.tool_radius_mm;
  const Vector3d eye = s.camera.eye_mm();
  const Vector3d view = s.camera.view_direction();
  const Vector3d ray = s.camera.pixel_ray(static_cast<int>(input.cursor_x),
                                          static_cast<int>(input.cursor_y), window_w, window_h);
  const std::optional<Vector3d> hit =
      render::pick_surface(s.renderer->volume(), eye, ray, options_.surface_density);
  if (input.press_pending) {
    input.press_pending = false;
    ++report_.presses;
    if (!hit) ++report_.picks_missed;
    segment_.press_ticks.push_back(std::max<std::int64_t>(felt_tick, 0));
    s.drag_point = hit ? *hit : s.target;  // nothing under the cursor: the tool's own depth
    input.push_mm = 0.0;
    s.dragging = true;
  }
  // Clear of the material: the tool's whole sphere and a millimetre more, backed off
  // towards the eye (render/pick.h), never a standoff that a narrow groove's far wall
  // would touch.
  const double clearance_mm = radius + 1.0;
  const double reach_mm = 10.0 * radius + 20.0;
  if (!input.left_down && s.dragging) {
    // The stroke ends: the tool lifts back out towards the eye.
    s.dragging = false;
    s.target = render::clear_of_material(s.renderer->volume(), s.target, -view, clearance_mm,
                                         options_.surface_density, reach_mm);
    input.push_mm = 0.0;
  } else if (s.dragging) {
    const double along = ray.dot(view);
    if (along > 1e-9) {
      const Vector3d on_plane = eye + ((s.drag_point - eye).dot(view) / along) * ray;
      s.target = on_plane + input.push_mm * view;
    }
  } else if (hit) {
    // Hovering over the surface under the cursor (pulled further out by a negative push).
    s.target =
        render::clear_of_material(s.renderer->volume(), *hit + std::min(0.0, input.push_mm) * view,
                                  -view, clearance_mm, options_.surface_density, reach_mm);
  }
  mouse_->set_target(frame_.grid_to_world(s.target), input.dead_man);
}

void SculptWindow::run(haptics::RenderFeed& feed, haptics::RenderTiming& timing) {
  if (!session_) open();
  Session& s = *session_;
  glfwMakeContextCurrent(s.window);
  // However the segment ends, this thread lets the context go: the next segment's render
  // thread (or close()) takes it.
  struct LetGo {
    ~LetGo() { glfwMakeContextCurrent(nullptr); }
  } let_go;
  s.renderer = std::make_unique<render::VolumeRenderer>(
      *field_copy_, render::TransferFunction::from_spec(setup_.transfer_spec));
  s.resampler.reset();
  if (segment_setup_.proxy_mesh) {
    s.resampler =
        std::make_unique<render::ProxyResampler>(render::dense_copy(*field_copy_), setup_.resample);
  }
  int mesh_index = -1;              // the mesh s.resampler deforms with
  std::int64_t deformed_tick = -1;  // the FEM step the texture shows
  Input& input = s.input;
  input.press_pending = false;
  input.segment_key.reset();
  haptics::WatchedDevice& device = *device_;

  const double radius = segment_setup_.tool_radius_mm;
  const Eigen::Matrix3d to_grid = frame_.direction().transpose();  // world -> grid vectors
  s.drag_point = s.target;
  s.dragging = false;
  const bool& dragging = s.dragging;
  std::vector<std::string> screenshots;
  const auto period = std::chrono::nanoseconds(std::llround(1e9 / options_.fps));
  auto next = Clock::now();
  haptics::VoxelPatch patch;
  Vector3d view = s.camera.view_direction();
  auto can_undo = [&] {
    return segment_setup_.can_undo || (segment_setup_.plastic && !segment_.press_ticks.empty());
  };
  // The script's clock runs from the first frame that sees a tick: a force loop slow to
  // start (a loaded machine) must not find the strokes over before its first tick.
  const double segment_script_s = s.script_s;
  std::optional<Clock::time_point> segment_start;
  while (true) {
    const bool finishing = feed.done.load(std::memory_order_acquire);
    const auto begin = Clock::now();
    if (!segment_start && feed.tool.read().tick >= 0) segment_start = begin;
    const double t_s =
        segment_script_s +
        (segment_start ? std::chrono::duration<double>(begin - *segment_start).count() : 0.0);
    s.script_s = t_s;
    glfwPollEvents();
    // Once a key has ended the segment, the script waits for the next one: what it does next
    // belongs to the changed tool or clay.
    if (segment_start && segment_.end == SegmentEnd::kQuit) {
      play_script(options_.script, s.next_event, t_s, input, options_.push_step_mm, screenshots);
    }
    if (glfwWindowShouldClose(s.window) || input.end_requested) device.request_end();
    // A key that changes the tool or the clay ends the segment, between strokes only.
    if (input.segment_key) {
      // A device program moving the tool (--device) holds the session: no segments.
      const SegmentEnd key = *input.segment_key;
      const bool allowed =
          mouse_ != nullptr && !dragging && !input.left_down &&
          (key != SegmentEnd::kUndo || can_undo()) &&
          (key != SegmentEnd::kTogglePlastic || segment_setup_.can_toggle_plastic) &&
          (key != SegmentEnd::kSwitchModel || segment_setup_.can_switch_model);
      if (allowed && !input.end_requested && segment_.end == SegmentEnd::kQuit) {
        segment_.end = *input.segment_key;
        device.request_end();
      }
      input.segment_key.reset();
    }
    while (feed.voxels.pop(patch)) {
      s.renderer->set_voxel(patch.ijk, patch.density);
      ++timing.voxels_applied;
    }
    if (s.resampler) {  // the FEM's latest step, resampled into the texture
      const haptics::MeshDisplacement& latest = feed.mesh.read();
      if (latest.tick >= 0 && latest.tick != deformed_tick) {
        if (latest.mesh_index != mesh_index) {
          s.resampler->set_mesh(*latest.mesh);
          mesh_index = latest.mesh_index;
        }
        // On this thread only: TBB's workers would compete with the force and FEM threads.
        tbb::task_arena one_thread(1);
        one_thread.execute([&] {
          s.resampler->update(Eigen::Map<const Eigen::VectorXd>(
              latest.displacement_mm.data(),
              static_cast<Eigen::Index>(latest.displacement_mm.size())));
        });
        s.renderer->replace_texels(s.resampler->texels(), s.resampler->changed_bricks());
        deformed_tick = latest.tick;
        ++report_.fem_steps_drawn;
      }
    }
    s.camera.azimuth_deg += input.orbit_deg[0];
    s.camera.elevation_deg = std::clamp(s.camera.elevation_deg + input.orbit_deg[1], -85.0, 85.0);
    input.orbit_deg[0] = input.orbit_deg[1] = 0.0;

    int window_w = 0, window_h = 0, frame_w = 0, frame_h = 0;
    glfwGetWindowSize(s.window, &window_w, &window_h);
    glfwGetFramebufferSize(s.window, &frame_w, &frame_h);
    window_w = std::max(window_w, 1), window_h = std::max(window_h, 1);
    frame_w = std::max(frame_w, 16), frame_h = std::max(frame_h, 16);
    view = s.camera.view_direction();
    const haptics::DeviceFeedback felt = device.feedback();
    if (mouse_ != nullptr) {
      steer_tool(window_w, window_h, felt.tick);
    } else {
      input.press_pending = false;  // a device program moves the tool: no strokes here
    }

    // The volume as the render thread's copy has it, the tool where the force thread put it.
    const haptics::RenderToolState tool = feed.tool.read();
    render::ToolPose pose;
    if (tool.tick >= 0) {
      pose.center_mm = frame_.world_to_grid(tool.center_mm);
      pose.radius_mm = radius;
      if (!s.resampler) {  // the FFD's press; the proxy mesh's deformation is in the texture
        pose.displacement_mm = to_grid * tool.displacement_mm;
        pose.in_contact = tool.in_contact;
      }
    }
    render::RenderSettings settings = setup_.settings;
    settings.width = frame_w;
    settings.height = frame_h;
    const render::Image image = s.renderer->render(s.camera, pose, settings);
    glBindTexture(GL_TEXTURE_2D, s.texture);
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
        reinterpret_cast<ImTextureID>(static_cast<std::intptr_t>(s.texture)), ImVec2(0, 0), size);
    // The force: an arrow from the tool's centre, and its magnitude beside the tip.
    const Vector3d force_world(felt.force_n[0], felt.force_n[1], felt.force_n[2]);
    const double force_n = force_world.norm();
    if (tool.tick >= 0 && force_n > 1e-3) {
      const Vector3d tip = pose.center_mm + options_.arrow_mm_per_n * (to_grid * force_world);
      const auto from = project(s.camera, pose.center_mm, window_w, window_h);
      const auto to = project(s.camera, tip, window_w, window_h);
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
    if (segment_setup_.plastic) {
      ImGui::Text("model  %s  tool %.1f mm  mass %lld units  %s",
                  segment_setup_.model_label.c_str(), 2.0 * radius,
                  static_cast<long long>(feed.loop.total_mass_units.load()),
                  felt.contact ? "contact" : "free");
    } else {
      ImGui::Text("model  %s  tool %.1f mm  %s", segment_setup_.model_label.c_str(), 2.0 * radius,
                  felt.contact ? "contact" : "free");
    }
    if (mouse_ != nullptr) {
      ImGui::Text("tool   %s  push %+.1f mm  tick %lld", dragging ? "dragging" : "hovering",
                  input.push_mm, static_cast<long long>(felt.tick));
      ImGui::Text("keys   [ ] tool size  %s%s  %s  space dead-man  esc end",
                  segment_setup_.can_toggle_plastic ? "p plastic  " : "",
                  segment_setup_.can_switch_model ? "m voxel/FEM" : "(m: --materials)",
                  can_undo() ? "z undo" : "(nothing to undo)");
    } else {
      ImGui::Text("tool   moved by %s  tick %lld", segment_setup_.device_label.c_str(),
                  static_cast<long long>(felt.tick));
      ImGui::Text("keys   left/right orbit  esc end");
    }
    ImGui::End();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    const bool last_of_session = finishing && segment_.end == SegmentEnd::kQuit;
    if (last_of_session && !options_.screenshot.empty()) {
      screenshots.push_back(options_.screenshot);
    }
    for (const std::string& path : screenshots) {
      render::write_png(read_window(frame_w, frame_h), path);
      report_.screenshots.push_back(path);
    }
    screenshots.clear();
    glfwSwapBuffers(s.window);
    ++report_.frames;
    timing.record_frame(feed.start, begin, tool.tick);
    if (finishing) break;
    next = std::max(next + period, Clock::now());
    while (Clock::now() < next && !feed.done.load(std::memory_order_acquire)) {
      std::this_thread::sleep_for(
          std::min<Clock::duration>(next - Clock::now(), std::chrono::milliseconds(2)));
    }
  }
  // The next segment's tool starts where the force thread left this one's.
  const haptics::DeviceFeedback last = device.feedback();
  segment_.last_position_mm =
      last.tick >= 0 ? Vector3d(last.position_mm[0], last.position_mm[1], last.position_mm[2])
                     : frame_.grid_to_world(s.target);
  segment_.view_direction = frame_.direction() * view;
}

}  // namespace hapvox::cli
