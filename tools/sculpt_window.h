#pragma once
// The window of `hapvox sculpt` (GLFW, Debian libglfw3-dev; the overlay through Dear ImGui,
// libimgui-dev): the live render of the volume, the tool the mouse drags and the force it
// feels as an arrow and a number, with the force loop's rate, p99 lateness and missed ticks.
//
// It is the realtime loop's render loop (haptics::RenderLoop): everything here runs on the
// render thread, which owns the window, its OpenGL context, the renderer's copy of the
// volume and all input. The tool reaches the force thread only as a MouseDevice target.
//
// Input (a person's, or a script's: haptics/pointer_script.h, driven through the same
// handlers):
//   move            the tool follows the cursor, hovering 1 mm clear of the surface under it
//   left drag       picks the surface point under the cursor (Nakao §3.2) and drags the
//                   tool on the view plane through it; the tool's centre starts on the
//                   surface (half the tool pressed in); on release it lifts back out
//   wheel, up/down  push the tool in (+) or pull it out along the view, 0.5 mm a notch
//   space (held)    the dead-man: the force ramps out while it is held
//   left/right      orbit the camera 5 degrees (or drag with the right button)
//   [ / ]           a smaller / larger tool        } each ends the session's segment (the
//   p               plastic on or off              } force loop stops, the force at zero)
//   z               undo the last plastic stroke   } and tools/cmd_sculpt.cc starts the next;
//   m               the voxel or the FEM model     } ignored during a stroke
//   escape, close   end the session
//
// With the FEM model (Nakao's proxy mesh) the window draws the volume as the mesh deforms
// it: each FEM step's node displacements resample the volume's texture (as `replay --model
// fem --render-dir` frames do), on this thread.
//
// The window lives across segments: each segment's loop takes the OpenGL context on its
// render thread and lets it go at the end; close() (or the destructor) closes it.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "engine/density_field.h"
#include "haptics/mouse_device.h"
#include "haptics/pointer_script.h"
#include "haptics/render_feed.h"
#include "haptics/watched_device.h"
#include "tools/render_output.h"

namespace hapvox::cli {

struct SculptWindowOptions {
  int width = 800, height = 600;  // the window (and the rendered frame), pixels
  double fps = 60.0;
  double surface_density = 0.5;  // picking stops where the density reaches this
  double push_step_mm = 0.5;     // a wheel notch or an up/down key
  double arrow_mm_per_n = 20.0;  // the force arrow's length
  std::vector<haptics::PointerEvent> script;
  std::string screenshot;  // the window's last frame as a PNG (empty: none)
};

/// What one segment runs with.
struct SculptSegmentSetup {
  double tool_radius_mm = 4.0;
  std::string model_label = "voxel";   // the overlay's model line
  bool plastic = true;                 // the segment sculpts: its strokes can be undone
  bool can_undo = false;               // an earlier segment's plastic stroke is there to undo
  std::string device_label = "mouse";  // without a mouse: what moves the tool (the overlay)
  bool proxy_mesh = false;             // the FEM model: draw the feed's mesh displacements
  bool can_toggle_plastic = true;      // p is taken (the voxel model)
  bool can_switch_model = false;       // m is taken (a materials file makes the FEM model)
};

/// Why the window ended a segment (tools/cmd_sculpt.cc starts the next one, or stops).
enum class SegmentEnd { kQuit, kSmallerTool, kLargerTool, kTogglePlastic, kUndo, kSwitchModel };

/// What one segment's window did.
struct SculptSegmentReport {
  SegmentEnd end = SegmentEnd::kQuit;
  /// The tick the force thread had last sent when each stroke began (left button down):
  /// the clay before it is the segment's replay up to that tick.
  std::vector<std::int64_t> press_ticks;
  Eigen::Vector3d last_position_mm = Eigen::Vector3d::Zero();  // volume mm, the tool at the end
  Eigen::Vector3d view_direction = Eigen::Vector3d::UnitZ();   // volume frame, into the view
};

/// What the window did over the whole session.
struct SculptWindowReport {
  int frames = 0;
  std::vector<std::string> screenshots;  // written, in order
  int presses = 0;                       // strokes begun (left button down)
  int picks_missed = 0;                  // presses whose ray saw no surface
  int fem_steps_drawn = 0;               // FEM steps the volume was resampled for
};

class SculptWindow {
 public:
  /// Checks that a window can open (a display is there) before any output is made; the
  /// window itself opens on the first segment's render thread. `frame` gives the volume's
  /// geometry (world <-> grid), the same for every segment (its voxels are not kept).
  SculptWindow(const engine::DensityField& frame, const RenderSetup& setup,
               SculptWindowOptions options);
  ~SculptWindow();

  /// The render loop of one segment for haptics::replay_realtime: opens the window (the
  /// first time) or takes it over, draws `field` (copied now, before any thread runs) and
  /// the tool `device` moves until the feed is done, then a last frame (and, at the end of
  /// the session, the --screenshot). `mouse`, when the device is one, takes the cursor's
  /// targets; without it (a device program moves the tool, --device) the window draws,
  /// orbits and ends the session, and takes no strokes or segment keys. Both must outlive
  /// the loop.
  haptics::RenderLoop loop(const engine::DensityField& field, haptics::WatchedDevice& device,
                           haptics::MouseDevice* mouse, SculptSegmentSetup setup);

  /// Closes the window (on the calling thread, once no segment runs).
  void close() noexcept;

  const SculptSegmentReport& segment() const { return segment_; }
  const SculptWindowReport& report() const { return report_; }

 private:
  struct Session;  // the window, its context, renderer and input, kept across segments
  void open();
  void run(haptics::RenderFeed& feed, haptics::RenderTiming& timing);
  // The mouse's stage of a frame: the tool's target from the cursor, handed to mouse_.
  void steer_tool(int window_w, int window_h, std::int64_t felt_tick);

  engine::DensityField frame_;  // the geometry only: no voxels
  RenderSetup setup_;
  SculptWindowOptions options_;
  std::unique_ptr<Session> session_;
  // This segment's.
  std::unique_ptr<engine::DensityField> field_copy_;
  haptics::WatchedDevice* device_ = nullptr;
  haptics::MouseDevice* mouse_ = nullptr;  // null: a device program moves the tool
  SculptSegmentSetup segment_setup_;
  SculptSegmentReport segment_;
  SculptWindowReport report_;
};

}  // namespace hapvox::cli
