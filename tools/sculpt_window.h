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
//   move            the tool follows the cursor, 2 mm clear of the surface under it
//   left drag       picks the surface point under the cursor (Nakao §3.2) and drags the
//                   tool on the view plane through it; the tool's centre starts on the
//                   surface (half the tool pressed in); on release it lifts back out
//   wheel, up/down  push the tool in (+) or pull it out along the view, 0.5 mm a notch
//   space (held)    the dead-man: the force ramps out while it is held
//   left/right      orbit the camera 5 degrees (or drag with the right button)
//   escape, close   end the session

#include <memory>
#include <string>
#include <vector>

#include "engine/density_field.h"
#include "haptics/mouse_device.h"
#include "haptics/pointer_script.h"
#include "haptics/render_feed.h"
#include "tools/render_output.h"

namespace hapvox::cli {

struct SculptWindowOptions {
  int width = 800, height = 600;  // the window (and the rendered frame), pixels
  double fps = 60.0;
  double tool_radius_mm = 4.0;
  double surface_density = 0.5;       // picking stops where the density reaches this
  double push_step_mm = 0.5;          // a wheel notch or an up/down key
  double arrow_mm_per_n = 20.0;       // the force arrow's length
  std::string model_label = "voxel";  // the overlay's model line
  std::vector<haptics::PointerEvent> script;
  std::string screenshot;  // the window's last frame as a PNG (empty: none)
};

/// What the window did, for the session's attributes and the report.
struct SculptWindowReport {
  int frames = 0;
  std::vector<std::string> screenshots;  // written, in order
  int presses = 0;                       // strokes begun (left button down)
  int picks_missed = 0;                  // presses whose ray saw no surface
};

class SculptWindow {
 public:
  /// Checks that a window can open (a display is there) before any output is made; the
  /// window itself opens on the render thread. `field` and `device` must outlive the loop.
  SculptWindow(const engine::DensityField& field, const RenderSetup& setup,
               haptics::MouseDevice& device, SculptWindowOptions options);

  /// The render loop for haptics::replay_realtime: opens the window, draws until the feed is
  /// done, then a last frame (and the --screenshot), and closes it.
  haptics::RenderLoop loop();

  const SculptWindowReport& report() const { return report_; }

 private:
  struct Session;  // the render thread's state (window, renderer, input)
  void run(haptics::RenderFeed& feed, haptics::RenderTiming& timing);

  const engine::DensityField& field_;  // its frame only (world <-> grid)
  std::unique_ptr<engine::DensityField> field_copy_;
  RenderSetup setup_;
  haptics::MouseDevice& device_;
  SculptWindowOptions options_;
  SculptWindowReport report_;
};

}  // namespace hapvox::cli
