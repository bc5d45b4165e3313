// The CPU ray-caster's camera (offline/render/cpu_reference.hpp) for a scene view: the same eye, target,
// field of view and image size the GPU renderers project with (View::view_proj).
#pragma once

#include "btflod/offline/render/cpu_reference.hpp"
#include "demo_scene.hpp"

namespace btflod::scene {

/// The CPU reference camera that sees what `view` sees.
inline Camera to_camera(const View& view) {
  Camera cam;
  cam.position = view.eye;
  cam.target = view.target;
  cam.fov_y_degrees = view.fov_y_degrees;
  cam.width = view.width;
  cam.height = view.height;
  return cam;
}

}  // namespace btflod::scene
