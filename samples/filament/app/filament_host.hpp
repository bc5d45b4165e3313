// Filament boilerplate of the sample, nothing btflod-specific: a headless OpenGL engine with two
// views of one camera (the colour view into an RGBA32F render target, so that the check sees the
// shader's values unrounded; an engine's HDR target would be RGBA16F,
// the feedback view into a small RGBA8 one), both cleared by a black skybox (render targets ignore
// the renderer's clear options), meshes with Filament's tangent frames, textures, and a
// synchronous readback.
// main.cpp holds everything that concerns btflod.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <filament/Camera.h>
#include <filament/Engine.h>
#include <filament/IndexBuffer.h>
#include <filament/Material.h>
#include <filament/MaterialInstance.h>
#include <filament/RenderTarget.h>
#include <filament/Renderer.h>
#include <filament/Scene.h>
#include <filament/Skybox.h>
#include <filament/SwapChain.h>
#include <filament/Texture.h>
#include <filament/TextureSampler.h>
#include <filament/VertexBuffer.h>
#include <filament/View.h>
#include <utils/Entity.h>

#include "btflod/offline/render/primitives.hpp"

namespace host {

struct Host {
  filament::Engine* engine = nullptr;
  filament::SwapChain* swap_chain = nullptr;
  filament::Renderer* renderer = nullptr;
  filament::Camera* camera = nullptr;
  utils::Entity camera_entity;
  filament::Scene* color_scene = nullptr;     // what the player sees
  filament::Scene* feedback_scene = nullptr;  // the same meshes with the feedback material
  filament::View* color_view = nullptr;
  filament::View* feedback_view = nullptr;
  filament::Texture* color_texture = nullptr;  // RGBA32F: the shader's values, unrounded (an engine: RGBA16F)
  filament::Texture* color_depth = nullptr;
  filament::RenderTarget* color_target = nullptr;
  filament::Texture* feedback_color = nullptr;
  filament::Texture* feedback_depth = nullptr;
  filament::RenderTarget* feedback_target = nullptr;
  filament::Skybox* skybox = nullptr;
  uint32_t width = 0, height = 0, feedback_width = 0, feedback_height = 0;
  std::vector<filament::VertexBuffer*> vertex_buffers;
  std::vector<filament::IndexBuffer*> index_buffers;
  std::vector<utils::Entity> renderables;
  // Feedback readbacks in flight: a ring polled every frame, never waited on (DESIGN.md).
  struct Readback {
    std::vector<uint8_t> bytes;
    uint64_t frame = 0;
    bool in_flight = false, ready = false;
  };
  static constexpr int kReadbacks = 3;
  Readback readbacks[kReadbacks];
  uint64_t frame = 0;
};

/// Creates the engine (OpenGL backend), a headless swap chain of width × height, the two views
/// with post-processing, anti-aliasing and dithering off, and the feedback target. Returns false
/// (with a message on stderr) when Filament cannot start (no X display, no GL).
bool create(Host& h, uint32_t width, uint32_t height, uint32_t feedback_width, uint32_t feedback_height);
/// Destroys the meshes' renderables and buffers (before the material instances they use).
void destroy_meshes(Host& h);
/// Destroys the rest and the engine (after every texture, material and instance of the caller).
void destroy(Host& h);

/// Loads a material compiled by matc.
filament::Material* load_material(Host& h, const std::string& path);

/// Adds `mesh` twice: drawn with `color` in the colour scene and with `feedback` in the
/// feedback scene (Filament tangent frames from the mesh's normals and tangents).
void add_mesh(Host& h, const btflod::TriangleMeshData& mesh, filament::MaterialInstance* color,
              filament::MaterialInstance* feedback);

/// Draws mesh `mesh` (in add_mesh order) of the colour scene with another material instance.
void set_color_material(Host& h, size_t mesh, filament::MaterialInstance* color);

/// Sets the camera of both views (vertical field of view in degrees).
void set_camera(Host& h, glm::vec3 eye, glm::vec3 target, glm::vec3 up, float fov_y_degrees);

/// A 2D-array texture of width × height texels and `layers` layers of `format`, one mip level,
/// for a material to sample; its texels are set with set_image.
filament::Texture* create_array_texture(filament::Engine& engine, uint32_t width, uint32_t height, uint32_t layers,
                                        filament::Texture::InternalFormat format);

/// Copies `bytes` and hands them to Texture::setImage for the sub-box (x, y, z) + (w, h, d) of
/// mip `level` (Filament frees the copy once the driver consumed it).
void set_image(Host& h, filament::Texture* t, uint32_t level, uint32_t x, uint32_t y, uint32_t z, uint32_t w,
               uint32_t hgt, uint32_t d, const void* bytes, size_t size, filament::Texture::Format format,
               filament::Texture::Type type);
/// The same for the sub-rectangle (x, y) + (w, h) of mip 0 of a 2D texture.
void set_image_2d(Host& h, filament::Texture* t, uint32_t x, uint32_t y, uint32_t w, uint32_t hgt, const void* bytes,
                  size_t size, filament::Texture::Format format, filament::Texture::Type type);

/// Renders both views and starts a readback of the feedback target (RGBA8) into a ring of
/// kReadbacks buffers; never waits for it. Returns true with the newest feedback image that has
/// landed since the last call in `feedback_rgba` (typically one or two frames old), false when none
/// has. When `color` is not null, also reads back the colour view (RGBA float, linear) and waits
/// for it and for this frame's feedback (a frame to write or check: both then show this frame).
/// Rows come top row first: Filament renders into render targets upside down relative to
/// OpenGL's convention, so its readback of one is top-down.
bool render(Host& h, std::vector<uint8_t>& feedback_rgba, std::vector<float>* color);

}  // namespace host
