#include "filament_host.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>

#include <filament/RenderableManager.h>
#include <filament/Skybox.h>
#include <filament/Viewport.h>
#include <geometry/SurfaceOrientation.h>
#include <math/quat.h>
#include <math/vec3.h>
#include <math/vec4.h>
#include <utils/EntityManager.h>

using namespace filament;

namespace host {

namespace {

// An offscreen render target of width × height: a sampleable colour texture of `color_format`
// and a DEPTH24 depth texture.
void create_render_target(Engine& engine, uint32_t width, uint32_t height, Texture::InternalFormat color_format,
                          Texture*& color, Texture*& depth, RenderTarget*& target) {
  color = Texture::Builder()
              .width(width)
              .height(height)
              .levels(1)
              .usage(Texture::Usage::COLOR_ATTACHMENT | Texture::Usage::SAMPLEABLE)
              .format(color_format)
              .build(engine);
  depth = Texture::Builder()
              .width(width)
              .height(height)
              .levels(1)
              .usage(Texture::Usage::DEPTH_ATTACHMENT)
              .format(Texture::InternalFormat::DEPTH24)
              .build(engine);
  target = RenderTarget::Builder()
               .texture(RenderTarget::AttachmentPoint::COLOR, color)
               .texture(RenderTarget::AttachmentPoint::DEPTH, depth)
               .build(engine);
}

}  // namespace

Texture* create_array_texture(Engine& engine, uint32_t width, uint32_t height, uint32_t layers,
                              Texture::InternalFormat format) {
  return Texture::Builder()
      .width(width)
      .height(height)
      .depth(layers)
      .sampler(Texture::Sampler::SAMPLER_2D_ARRAY)
      .format(format)
      .build(engine);
}

bool create(Host& h, uint32_t width, uint32_t height, uint32_t fw, uint32_t fh) {
  h.width = width;
  h.height = height;
  h.feedback_width = fw;
  h.feedback_height = fh;
  h.engine = Engine::create(Engine::Backend::OPENGL);
  if (!h.engine) return std::fprintf(stderr, "Filament: no OpenGL engine (is an X display set?)\n"), false;
  h.swap_chain = h.engine->createSwapChain(width, height, 0);
  h.renderer = h.engine->createRenderer();
  h.renderer->setClearOptions({.clearColor = {0.0f, 0.0f, 0.0f, 0.0f}, .clear = true, .discard = true});
  h.camera_entity = utils::EntityManager::get().create();
  h.camera = h.engine->createCamera(h.camera_entity);
  h.color_scene = h.engine->createScene();
  h.feedback_scene = h.engine->createScene();
  create_render_target(*h.engine, width, height, Texture::InternalFormat::RGBA32F, h.color_texture, h.color_depth,
                       h.color_target);
  create_render_target(*h.engine, fw, fh, Texture::InternalFormat::RGBA8, h.feedback_color, h.feedback_depth,
                       h.feedback_target);
  for (int k = 0; k < 2; ++k) {
    View* v = h.engine->createView();
    v->setCamera(h.camera);
    v->setScene(k == 0 ? h.color_scene : h.feedback_scene);
    v->setViewport({0, 0, k == 0 ? width : fw, k == 0 ? height : fh});
    // llvmpipe renders corrupt images with post-processing; the values must be btflod's anyway.
    v->setPostProcessingEnabled(false);
    v->setAntiAliasing(View::AntiAliasing::NONE);
    v->setDithering(View::Dithering::NONE);
    v->setShadowingEnabled(false);
    (k == 0 ? h.color_view : h.feedback_view) = v;
  }
  h.feedback_view->setRenderTarget(h.feedback_target);
  h.color_view->setRenderTarget(h.color_target);
  h.skybox = Skybox::Builder().color({0.0f, 0.0f, 0.0f, 0.0f}).build(*h.engine);
  h.color_scene->setSkybox(h.skybox);
  h.feedback_scene->setSkybox(h.skybox);
  return true;
}

void destroy_meshes(Host& h) {
  for (utils::Entity e : h.renderables) h.engine->destroy(e);
  for (auto* b : h.vertex_buffers) h.engine->destroy(b);
  for (auto* b : h.index_buffers) h.engine->destroy(b);
  h.renderables.clear();
  h.vertex_buffers.clear();
  h.index_buffers.clear();
}

void destroy(Host& h) {
  if (!h.engine) return;
  destroy_meshes(h);
  h.engine->destroy(h.color_view);
  h.engine->destroy(h.feedback_view);
  h.engine->destroy(h.feedback_target);
  h.engine->destroy(h.color_target);
  h.engine->destroy(h.color_texture);
  h.engine->destroy(h.color_depth);
  h.engine->destroy(h.skybox);
  h.engine->destroy(h.feedback_color);
  h.engine->destroy(h.feedback_depth);
  h.engine->destroy(h.color_scene);
  h.engine->destroy(h.feedback_scene);
  h.engine->destroyCameraComponent(h.camera_entity);
  h.engine->destroy(h.renderer);
  h.engine->destroy(h.swap_chain);
  Engine::destroy(&h.engine);
}

Material* load_material(Host& h, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.empty()) return std::fprintf(stderr, "cannot read %s\n", path.c_str()), nullptr;
  return Material::Builder().package(bytes.data(), bytes.size()).build(*h.engine);
}

namespace {
struct Vertex {
  math::float3 position;
  math::quatf tangent_frame;
  math::float2 uv;
};
}  // namespace

void add_mesh(Host& h, const btflod::TriangleMeshData& mesh, MaterialInstance* color, MaterialInstance* feedback) {
  const size_t n = mesh.vertices.size();
  std::vector<math::float3> normals(n);
  std::vector<math::float4> tangents(n);
  for (size_t i = 0; i < n; ++i) {
    const btflod::MeshVertex& v = mesh.vertices[i];
    normals[i] = {v.normal[0], v.normal[1], v.normal[2]};
    tangents[i] = {v.tangent[0], v.tangent[1], v.tangent[2], v.tangent[3]};
  }
  geometry::SurfaceOrientation* orientation =
      geometry::SurfaceOrientation::Builder().vertexCount(n).normals(normals.data()).tangents(tangents.data()).build();
  std::vector<math::quatf> quats(n);
  orientation->getQuats(quats.data(), n);
  delete orientation;
  auto* verts = static_cast<Vertex*>(std::malloc(n * sizeof(Vertex)));
  math::float3 lo(1e30f), hi(-1e30f);
  for (size_t i = 0; i < n; ++i) {
    const btflod::MeshVertex& v = mesh.vertices[i];
    verts[i] = {{v.position[0], v.position[1], v.position[2]}, quats[i], {v.uv[0], v.uv[1]}};
    lo = min(lo, verts[i].position);
    hi = max(hi, verts[i].position);
  }
  auto* indices = static_cast<uint32_t*>(std::malloc(mesh.indices.size() * 4));
  std::memcpy(indices, mesh.indices.data(), mesh.indices.size() * 4);
  const auto release = [](void* p, size_t, void*) { std::free(p); };
  VertexBuffer* vb =
      VertexBuffer::Builder()
          .vertexCount(static_cast<uint32_t>(n))
          .bufferCount(1)
          .attribute(VertexAttribute::POSITION, 0, VertexBuffer::AttributeType::FLOAT3, 0, sizeof(Vertex))
          .attribute(VertexAttribute::TANGENTS, 0, VertexBuffer::AttributeType::FLOAT4, 12, sizeof(Vertex))
          .attribute(VertexAttribute::UV0, 0, VertexBuffer::AttributeType::FLOAT2, 28, sizeof(Vertex))
          .build(*h.engine);
  vb->setBufferAt(*h.engine, 0, VertexBuffer::BufferDescriptor(verts, n * sizeof(Vertex), release));
  IndexBuffer* ib = IndexBuffer::Builder()
                        .indexCount(static_cast<uint32_t>(mesh.indices.size()))
                        .bufferType(IndexBuffer::IndexType::UINT)
                        .build(*h.engine);
  ib->setBuffer(*h.engine, IndexBuffer::BufferDescriptor(indices, mesh.indices.size() * 4, release));
  h.vertex_buffers.push_back(vb);
  h.index_buffers.push_back(ib);
  for (int k = 0; k < 2; ++k) {
    utils::Entity e = utils::EntityManager::get().create();
    RenderableManager::Builder(1)
        .boundingBox({(lo + hi) * 0.5f, (hi - lo) * 0.5f + 1e-3f})
        .material(0, k == 0 ? color : feedback)
        .geometry(0, RenderableManager::PrimitiveType::TRIANGLES, vb, ib)
        .culling(false)
        .castShadows(false)
        .receiveShadows(false)
        .build(*h.engine, e);
    (k == 0 ? h.color_scene : h.feedback_scene)->addEntity(e);
    h.renderables.push_back(e);
  }
}

void set_color_material(Host& h, size_t mesh, MaterialInstance* color) {
  RenderableManager& rm = h.engine->getRenderableManager();
  rm.setMaterialInstanceAt(rm.getInstance(h.renderables[2 * mesh]), 0, color);
}

void set_camera(Host& h, glm::vec3 eye, glm::vec3 target, glm::vec3 up, float fov_y_degrees) {
  h.camera->setProjection(fov_y_degrees, double(h.width) / h.height, 0.05, 50.0, Camera::Fov::VERTICAL);
  h.camera->lookAt({eye.x, eye.y, eye.z}, {target.x, target.y, target.z}, {up.x, up.y, up.z});
}

namespace {
// A copy of `bytes` that Filament frees once the driver consumed it.
Texture::PixelBufferDescriptor owned_copy(const void* bytes, size_t size, Texture::Format format, Texture::Type type) {
  void* copy = std::malloc(size);
  std::memcpy(copy, bytes, size);
  return Texture::PixelBufferDescriptor(copy, size, format, type, [](void* p, size_t, void*) { std::free(p); });
}
}  // namespace

void set_image(Host& h, Texture* t, uint32_t level, uint32_t x, uint32_t y, uint32_t z, uint32_t w, uint32_t hgt,
               uint32_t d, const void* bytes, size_t size, Texture::Format format, Texture::Type type) {
  t->setImage(*h.engine, level, x, y, z, w, hgt, d, owned_copy(bytes, size, format, type));
}

void set_image_2d(Host& h, Texture* t, uint32_t x, uint32_t y, uint32_t w, uint32_t hgt, const void* bytes, size_t size,
                  Texture::Format format, Texture::Type type) {
  t->setImage(*h.engine, 0, x, y, w, hgt, owned_copy(bytes, size, format, type));
}

bool render(Host& h, std::vector<uint8_t>& feedback_rgba, std::vector<float>* color) {
  const size_t feedback_bytes = size_t{h.feedback_width} * h.feedback_height * 4;
  if (color) {  // a frame to write or check: drain the ring so that this frame's feedback is returned
    for (Host::Readback& r : h.readbacks)
      while (r.in_flight) h.engine->flushAndWait();
    for (Host::Readback& r : h.readbacks) r.ready = false;
  }
  // A free ring slot for this frame's feedback readback (none free: this frame reads nothing back).
  Host::Readback* slot = nullptr;
  for (Host::Readback& r : h.readbacks)
    if (!r.in_flight && !r.ready) slot = &r;
  int color_pending = 0;
  const auto landed = [](void*, size_t, void* user) {  // on this thread, in a later beginFrame/flush
    auto* r = static_cast<Host::Readback*>(user);
    r->in_flight = false;
    r->ready = true;
  };
  while (!h.renderer->beginFrame(h.swap_chain)) {
  }
  h.renderer->render(h.feedback_view);
  if (slot) {
    slot->bytes.resize(feedback_bytes);
    slot->frame = h.frame;
    slot->in_flight = true;
    h.renderer->readPixels(
        h.feedback_target, 0, 0, h.feedback_width, h.feedback_height,
        {slot->bytes.data(), feedback_bytes, Texture::Format::RGBA, Texture::Type::UBYTE, landed, slot});
  }
  h.renderer->render(h.color_view);
  if (color) {
    color->assign(size_t{h.width} * h.height * 4, 0.0f);
    color_pending = 1;
    h.renderer->readPixels(h.color_target, 0, 0, h.width, h.height,
                           {color->data(), color->size() * 4, Texture::Format::RGBA, Texture::Type::FLOAT,
                            [](void*, size_t, void* user) { --*static_cast<int*>(user); }, &color_pending});
  }
  h.renderer->endFrame();
  ++h.frame;
  // A colour readback is waited for (a frame to write, or to check): then this frame's feedback
  // is the newest too.
  while (color_pending > 0 || (color && slot && slot->in_flight)) h.engine->flushAndWait();
  // The newest landed feedback image, if any; older landed ones are stale and dropped.
  Host::Readback* newest = nullptr;
  for (Host::Readback& r : h.readbacks)
    if (r.ready && (!newest || r.frame > newest->frame)) newest = &r;
  if (!newest) return false;
  feedback_rgba.swap(newest->bytes);
  for (Host::Readback& r : h.readbacks)
    if (r.ready) r.ready = false;
  return true;
}

}  // namespace host
