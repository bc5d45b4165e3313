// Golden image of an ENGINE-STYLE shader on Vulkan 1.3 (headless, lavapipe), the twin of
// test_golden_engine_gl.cpp: the engine owns the descriptor set layouts and the pipeline layout
// (set 0: its camera and surface uniform blocks; set 1: the material's samplers at bindings 2–6
// and the tile cache it declares itself at binding 9), writes its own vertex shader (its own
// attribute locations) and fragment main(), and calls the functions of generate_functions()
// (prefix "mat_", GlslTarget::vulkan450, per-role set and binding from GlslFunctionOptions,
// uniform sources pointing at the engine's block), compiled to SPIR-V with the Vulkan sample's
// glslc helper; its device, buffers, images and pipeline come from the sample's helpers too
// (vk_internal.hpp). One shader holds the fmf and bsvtf pieces and picks one per draw from its
// surface block. The scene, material and partial tile cache are those of test_golden_scene.hpp;
// the image must match the CPU reference (offline/render/cpu_reference.hpp) at PSNR >= 40 dB, and a
// wrong variant (BSVTF read at the finest level everywhere) must not.
// Skips with the reason when no Vulkan 1.3 device or no glslc is available.
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <deque>
#include <string>
#include <vector>

#include "btflod/runtime/shader/glsl_generator.hpp"
#include "test_golden_engine_blocks.hpp"
#include "test_golden_scene.hpp"
#include "vk_internal.hpp"

// `VkFooCreateInfo info{VK_STRUCTURE_TYPE_...}` value-initialises the rest: idiomatic, not a bug.
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace {

using namespace btflod;
using namespace btflod::golden;

constexpr uint32_t kEngineSet = 0, kCameraBinding = 0, kSurfaceBinding = 1;
constexpr uint32_t kMaterialSet = 1, kEngineCacheBinding = 9;

const char* kEngineVertex = R"(#version 450
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec3 a_normal;
layout(location = 3) in vec4 a_tangent;
layout(std140, set = 0, binding = 0) uniform EngineCamera { mat4 view_proj; vec4 eye; } camera;
layout(location = 0) out vec3 p_world; layout(location = 1) out vec3 p_normal;
layout(location = 2) out vec4 p_tangent; layout(location = 3) out vec2 p_uv;
void main() {
  p_world = a_position; p_normal = a_normal; p_tangent = a_tangent; p_uv = a_uv;
  gl_Position = camera.view_proj * vec4(a_position, 1.0);
  gl_Position.z = 0.5 * (gl_Position.z + gl_Position.w);  // GL clip depth -> Vulkan's [0, w]
}
)";

const char* kEngineFragmentHead = R"(#version 450
layout(std140, set = 0, binding = 0) uniform EngineCamera { mat4 view_proj; vec4 eye; } camera;
layout(std140, set = 0, binding = 1) uniform EngineSurface {
  vec4 sun_direction; vec4 sun_radiance; vec4 vt_extent; uvec4 layers; vec4 lod;
} surface;
layout(set = 1, binding = 9) uniform sampler2DArray g_vt_cache;  // declared by the engine, read by mat_bsvtf
layout(location = 0) in vec3 p_world; layout(location = 1) in vec3 p_normal;
layout(location = 2) in vec4 p_tangent; layout(location = 3) in vec2 p_uv;
layout(location = 0) out vec4 frag_color;
)";

#define VK_OK(expr) ASSERT_EQ((expr), VK_SUCCESS) << #expr

// A minimal engine-side Vulkan context: device, one queue, host-visible resources, one-shot
// submissions. Everything is destroyed by the destructor.
struct Engine : samples::vk_detail::VkDeviceContext {
  VkCommandPool pool = VK_NULL_HANDLE;
  using Tex = samples::vk_detail::Texture;
  using Buffer = samples::vk_detail::Buffer;
  std::deque<Tex> images;
  std::deque<Buffer> buffers;  // deque: references stay valid
  std::vector<VkSampler> samplers;

  ~Engine() {
    if (device) {
      vkDeviceWaitIdle(device);
      for (Tex& i : images) samples::vk_detail::destroy_texture(device, i);
      for (Buffer& b : buffers) samples::vk_detail::destroy_buffer(device, b);
      for (VkSampler s : samplers) vkDestroySampler(device, s, nullptr);
      vkDestroyCommandPool(device, pool, nullptr);
      vkDestroyDevice(device, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
  }

  // Returns "" on success, else why there is no usable device.
  std::string create() {
    if (VoidResult r = samples::vk_detail::create_vk13_device("engine", *this); !r) return r.message();
    VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pci.queueFamilyIndex = queue_family;
    if (vkCreateCommandPool(device, &pci, nullptr, &pool) != VK_SUCCESS) return "vkCreateCommandPool failed";
    return "";
  }

  // A host-visible, coherent, mapped buffer.
  Buffer& buffer(VkDeviceSize size, VkBufferUsageFlags usage) {
    Buffer b;
    const VoidResult r = samples::vk_detail::create_host_buffer(device, memory, b, size, usage);
    EXPECT_TRUE(r.ok()) << r.message();
    buffers.push_back(b);
    return buffers.back();
  }

  // A 2D array image (a 2D one for a colour attachment) in layout UNDEFINED: to_general() moves it.
  Tex image(VkFormat format, uint32_t w, uint32_t h, uint32_t layers, uint32_t mips, VkImageUsageFlags usage) {
    Tex i;
    const VoidResult r = samples::vk_detail::create_image(device, memory, i, format, w, h, layers, mips,
                                                          usage | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                                          (usage & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT) == 0);
    EXPECT_TRUE(r.ok()) << r.message();
    images.push_back(i);
    return i;
  }

  VkSampler sampler(VkFilter filter, VkSamplerAddressMode address) {
    VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    sci.magFilter = sci.minFilter = filter;
    sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    sci.addressModeU = sci.addressModeV = sci.addressModeW = address;
    sci.maxLod = VK_LOD_CLAMP_NONE;
    VkSampler s = VK_NULL_HANDLE;
    EXPECT_EQ(vkCreateSampler(device, &sci, nullptr, &s), VK_SUCCESS);
    samplers.push_back(s);
    return s;
  }

  static void to_general(VkCommandBuffer cmd, const Tex& i) {
    samples::vk_detail::to_general_layout(cmd, i.image, samples::vk_detail::texture_range(i));
  }

  VkCommandBuffer begin() {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    const VoidResult r = samples::vk_detail::begin_one_shot_commands(device, pool, cmd);
    EXPECT_TRUE(r.ok()) << r.message();
    return cmd;
  }

  void submit(VkCommandBuffer cmd) {
    samples::vk_detail::full_barrier(cmd);
    const VoidResult r = samples::vk_detail::submit_one_shot_commands(device, queue, pool, cmd);
    EXPECT_TRUE(r.ok()) << r.message();
  }

  // Copies `bytes` into region (mip, x, y, layer, w × h × 1) of `i` (already GENERAL).
  void upload(const Tex& i, const void* data, size_t bytes, uint32_t mip, int32_t x, int32_t y, uint32_t layer,
              uint32_t w, uint32_t h, uint32_t layers) {
    Buffer& staging = buffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
    std::memcpy(staging.mapped, data, bytes);
    VkCommandBuffer cmd = begin();
    VkBufferImageCopy c{};
    c.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, mip, layer, layers};
    c.imageOffset = {x, y, 0};
    c.imageExtent = {w, h, 1};
    vkCmdCopyBufferToImage(cmd, staging.buffer, i.image, VK_IMAGE_LAYOUT_GENERAL, 1, &c);
    submit(cmd);
  }
};

Result<VkShaderModule> shader_module(VkDevice device, const std::string& source, const char* stage) {
  Result<std::vector<uint32_t>> spirv = samples::vk_detail::compile_spirv(source, stage, "engine");
  if (!spirv) return spirv.error();
  VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = spirv->size() * 4;
  smci.pCode = spirv->data();
  VkShaderModule m = VK_NULL_HANDLE;
  if (vkCreateShaderModule(device, &smci, nullptr, &m) != VK_SUCCESS)
    return make_error(Status::unsupported, "vkCreateShaderModule failed");
  return m;
}

}  // namespace

TEST(GoldenEngineVk, EngineShaderCallingGeneratedFunctionsMatchesCpuReference) {
  Engine e;
  if (std::string why = e.create(); !why.empty()) GTEST_SKIP() << "GPU API unavailable: " << why;

  const ShaderConfig config = golden_config();
  const GlslFunctionOptions options = engine_function_options(2, kMaterialSet, kEngineCacheBinding);
  Result<GlslFunctionSource> fn = generate_functions(
      glsl_pieces({GlslPiece::fmf, GlslPiece::bsvtf, GlslPiece::local_frame}), GlslTarget::vulkan450, config, options);
  ASSERT_TRUE(fn.ok()) << fn.message();
  EXPECT_EQ(fn->code.find("g_vt_cache;"), std::string::npos) << "the engine declares the cache itself";
  EXPECT_EQ(fn->code.find("btflod"), std::string::npos) << "no default name may leak into the engine's shader";
  // Every sampler the functions read sits in the engine's material set at its chosen binding.
  for (const GlslSamplerUse& s : fn->samplers) {
    EXPECT_EQ(s.set, kMaterialSet) << s.name;
    EXPECT_EQ(s.binding, options.resource(s.role).binding) << s.name;
  }
  const std::string fragment = std::string(kEngineFragmentHead) + fn->code + kEngineFragmentMain;
  if (std::string(BTFLOD_GLSLC).empty()) GTEST_SKIP() << "GPU API unavailable: no glslc";
  Result<VkShaderModule> vs = shader_module(e.device, kEngineVertex, "vert");
  ASSERT_TRUE(vs.ok()) << vs.message();
  Result<VkShaderModule> fs = shader_module(e.device, fragment, "frag");
  ASSERT_TRUE(fs.ok()) << fs.message() << "\n" << fragment;

  // The engine's descriptor set layouts: set 0 its uniform blocks, set 1 the material samplers.
  VkDescriptorSetLayoutBinding ubo_bindings[2] = {};
  for (uint32_t i = 0; i < 2; ++i) {
    ubo_bindings[i].binding = i == 0 ? kCameraBinding : kSurfaceBinding;
    ubo_bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    ubo_bindings[i].descriptorCount = 1;
    ubo_bindings[i].stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  }
  std::vector<VkDescriptorSetLayoutBinding> tex_bindings;
  for (const GlslSamplerUse& s : fn->samplers)
    tex_bindings.push_back(
        {s.binding, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr});
  VkDescriptorSetLayout set_layouts[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  VkDescriptorSetLayoutCreateInfo lci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  lci.bindingCount = 2;
  lci.pBindings = ubo_bindings;
  VK_OK(vkCreateDescriptorSetLayout(e.device, &lci, nullptr, &set_layouts[kEngineSet]));
  lci.bindingCount = static_cast<uint32_t>(tex_bindings.size());
  lci.pBindings = tex_bindings.data();
  VK_OK(vkCreateDescriptorSetLayout(e.device, &lci, nullptr, &set_layouts[kMaterialSet]));
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 2;
  plci.pSetLayouts = set_layouts;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VK_OK(vkCreatePipelineLayout(e.device, &plci, nullptr, &layout));

  // The engine's pipeline: its attribute locations (position 0, uv 1, normal 2, tangent 3).
  const VkVertexInputAttributeDescription attrs[4] = {
      {0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, position)},
      {1, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(MeshVertex, uv)},
      {2, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, normal)},
      {3, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(MeshVertex, tangent)}};
  // Flipped viewport (negative height): row 0 of the target is the top of the image.
  const VkViewport viewport{
      0.0f, static_cast<float>(kSize), static_cast<float>(kSize), -static_cast<float>(kSize), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, {static_cast<uint32_t>(kSize), static_cast<uint32_t>(kSize)}};
  const VkFormat color_format = VK_FORMAT_R32G32B32A32_SFLOAT;
  samples::vk_detail::GraphicsPipelineDesc desc;
  desc.vertex = *vs;
  desc.fragment = *fs;
  desc.attributes = attrs;
  desc.attribute_count = 4;
  desc.color_formats = &color_format;
  desc.viewport = &viewport;
  desc.scissor = &scissor;
  desc.layout = layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VK_OK(samples::vk_detail::create_graphics_pipeline(e.device, desc, pipeline));
  vkDestroyShaderModule(e.device, *vs, nullptr);
  vkDestroyShaderModule(e.device, *fs, nullptr);

  // Material (FMF textures and U') and the partially filled tile cache of the golden scene.
  const EngineMaterial mat(config);
  if (HasFatalFailure()) return;
  const Material& m = mat.m;
  const PartialCacheScene& vt = mat.vt;
  std::vector<uint32_t> angular_index;
  std::vector<float> angular_weight;
  pack_angular_tables_rgba(mat.d.angular, angular_index, angular_weight);
  const uint32_t res = mat.d.angular.resolution;
  const VirtualTextureConfig& vc = config.vt;
  const uint32_t groups = config.component_groups(), pt_side = 1u << vc.finest_level;
  const VkImageUsageFlags sampled = VK_IMAGE_USAGE_SAMPLED_BIT;
  const Engine::Tex img_u = e.image(VK_FORMAT_R32G32B32A32_SFLOAT, m.lights, m.views, config.components, 1, sampled);
  const Engine::Tex img_v = e.image(VK_FORMAT_R32G32B32A32_SFLOAT, kTexture, kTexture, groups, 1, sampled);
  const Engine::Tex img_index = e.image(VK_FORMAT_R32G32B32A32_UINT, res, res, 2, 1, sampled);
  const Engine::Tex img_weight = e.image(VK_FORMAT_R32G32B32A32_SFLOAT, res, res, 2, 1, sampled);
  const Engine::Tex img_cache =
      e.image(VK_FORMAT_R16G16B16A16_SFLOAT, vc.cache_width(), vc.cache_height(), vc.cache_layers, 1, sampled);
  const Engine::Tex img_pt =
      e.image(VK_FORMAT_R32_UINT, pt_side, pt_side, vt.set.texture_count(), vc.finest_level + 1, sampled);
  const Engine::Tex color =
      e.image(color_format, kSize, kSize, 1, 1, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  {
    VkCommandBuffer cmd = e.begin();
    for (const Engine::Tex* i : {&img_u, &img_v, &img_index, &img_weight, &img_cache, &img_pt, &color})
      Engine::to_general(cmd, *i);
    // Unwritten page-table texels and cache texels start at zero (no resident tile).
    const VkClearColorValue zero{};
    for (const Engine::Tex* i : {&img_cache, &img_pt}) {
      const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, i->mips, 0, i->layers};
      vkCmdClearColorImage(cmd, i->image, VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    }
    e.submit(cmd);
  }
  e.upload(img_u, mat.u.data(), mat.u.size() * 4, 0, 0, 0, 0, m.lights, m.views, config.components);
  e.upload(img_v, mat.v.data(), mat.v.size() * 4, 0, 0, 0, 0, kTexture, kTexture, groups);
  e.upload(img_index, angular_index.data(), angular_index.size() * 4, 0, 0, 0, 0, res, res, 2);
  e.upload(img_weight, angular_weight.data(), angular_weight.size() * 4, 0, 0, 0, 0, res, res, 2);
  const uint32_t padded = vc.padded_tile_size();
  for (const TileUpload& t : vt.uploads) {
    const SlotPlacement p = slot_placement(vc, t.slot);
    e.upload(img_cache, t.texels.data(), t.texels.size() * 2, 0, static_cast<int32_t>(p.x), static_cast<int32_t>(p.y),
             p.layer, padded, padded, 1);
  }
  for (const PageTableWrite& w : vt.writes)
    e.upload(img_pt, &w.entry, 4, w.page_mip, static_cast<int32_t>(w.tile.x), static_cast<int32_t>(w.tile.y),
             w.tile.texture, 1, 1, 1);

  // Samplers as the GL engine test sets them; each texture goes where the options put it.
  const VkSampler nearest = e.sampler(VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
  const VkSampler linear_clamp = e.sampler(VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
  const VkSampler linear_repeat = e.sampler(VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_REPEAT);
  const struct {
    ShaderBinding role;
    VkSampler sampler;
    VkImageView view;
  } textures[] = {{ShaderBinding::eigen_abrdfs, nearest, img_u.view},
                  {ShaderBinding::eigen_textures, linear_repeat, img_v.view},
                  {ShaderBinding::angular_index, nearest, img_index.view},
                  {ShaderBinding::angular_weight, linear_clamp, img_weight.view},
                  {ShaderBinding::tile_cache, linear_clamp, img_cache.view},
                  {ShaderBinding::page_table, nearest, img_pt.view}};
  auto texture_of = [&](ShaderBinding role) -> VkDescriptorImageInfo {
    for (const auto& t : textures)
      if (t.role == role) return {t.sampler, t.view, VK_IMAGE_LAYOUT_GENERAL};
    ADD_FAILURE() << "unexpected sampler role " << shader_binding_name(role);
    return {};
  };

  // The engine's uniforms, from the golden scene's parameters.
  const ShaderParams params = golden_params(golden_camera());
  const EngineCamera cam{params.model_view_proj, params.camera_pos};
  EngineSurface surf{params.light, params.light_color, params.vt_extent, glm::uvec4(0, 0, 0, 0), params.lod};
  Engine::Buffer& ubo_cam = e.buffer(sizeof(cam), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  std::memcpy(ubo_cam.mapped, &cam, sizeof(cam));
  Engine::Buffer* ubo_surf[2] = {&e.buffer(sizeof(surf), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT),
                                 &e.buffer(sizeof(surf), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT)};
  std::memcpy(ubo_surf[0]->mapped, &surf, sizeof(surf));
  surf.layers.y = 1;
  std::memcpy(ubo_surf[1]->mapped, &surf, sizeof(surf));

  // Descriptor sets: one engine set per draw (fmf, bsvtf), one material set.
  const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 4},
                                         {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 8}};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 3;
  dpci.poolSizeCount = 2;
  dpci.pPoolSizes = sizes;
  VkDescriptorPool dpool = VK_NULL_HANDLE;
  VK_OK(vkCreateDescriptorPool(e.device, &dpci, nullptr, &dpool));
  const VkDescriptorSetLayout alloc_layouts[3] = {set_layouts[kEngineSet], set_layouts[kEngineSet],
                                                  set_layouts[kMaterialSet]};
  VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = dpool;
  dsai.descriptorSetCount = 3;
  dsai.pSetLayouts = alloc_layouts;
  VkDescriptorSet sets[3] = {};
  VK_OK(vkAllocateDescriptorSets(e.device, &dsai, sets));
  std::vector<VkWriteDescriptorSet> writes;
  VkDescriptorBufferInfo buffer_infos[4];
  for (int draw = 0; draw < 2; ++draw) {
    buffer_infos[2 * draw] = {ubo_cam.buffer, 0, sizeof(cam)};
    buffer_infos[2 * draw + 1] = {ubo_surf[draw]->buffer, 0, sizeof(surf)};
    for (uint32_t b = 0; b < 2; ++b) {
      VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      w.dstSet = sets[draw];
      w.dstBinding = b == 0 ? kCameraBinding : kSurfaceBinding;
      w.descriptorCount = 1;
      w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
      w.pBufferInfo = &buffer_infos[2 * draw + b];
      writes.push_back(w);
    }
  }
  std::vector<VkDescriptorImageInfo> image_infos;
  image_infos.reserve(fn->samplers.size());
  for (const GlslSamplerUse& s : fn->samplers) {
    image_infos.push_back(texture_of(s.role));
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = sets[2];
    w.dstBinding = s.binding;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    w.pImageInfo = &image_infos.back();
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(e.device, static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);

  // Engine mesh.
  std::vector<MeshVertex> verts;
  std::vector<uint32_t> idx;
  plane_mesh(PlaneSetup{}, verts, idx);
  Engine::Buffer& vbo = e.buffer(verts.size() * sizeof(MeshVertex), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
  std::memcpy(vbo.mapped, verts.data(), verts.size() * sizeof(MeshVertex));
  Engine::Buffer& ibo = e.buffer(idx.size() * sizeof(uint32_t), VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
  std::memcpy(ibo.mapped, idx.data(), idx.size() * sizeof(uint32_t));
  const size_t image_bytes = static_cast<size_t>(kSize) * kSize * 16;
  Engine::Buffer& readback = e.buffer(image_bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT);

  auto render = [&](int draw) {
    VkCommandBuffer cmd = e.begin();
    const VkClearColorValue zero{};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, color.image, VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    samples::vk_detail::full_barrier(cmd);
    VkRenderingAttachmentInfo att{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    att.imageView = color.view;
    att.imageLayout = VK_IMAGE_LAYOUT_GENERAL;
    att.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    att.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = scissor;
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &att;
    vkCmdBeginRendering(cmd, &ri);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    const VkDescriptorSet bound[2] = {sets[draw], sets[2]};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 2, bound, 0, nullptr);
    const VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &vbo.buffer, &offset);
    vkCmdBindIndexBuffer(cmd, ibo.buffer, 0, VK_INDEX_TYPE_UINT32);
    vkCmdDrawIndexed(cmd, static_cast<uint32_t>(idx.size()), 1, 0, 0, 0);
    vkCmdEndRendering(cmd);
    samples::vk_detail::full_barrier(cmd);
    VkBufferImageCopy c{};
    c.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    c.imageExtent = {static_cast<uint32_t>(kSize), static_cast<uint32_t>(kSize), 1};
    vkCmdCopyImageToBuffer(cmd, color.image, VK_IMAGE_LAYOUT_GENERAL, readback.buffer, 1, &c);
    e.submit(cmd);
    Image<float> img(kSize, kSize, 4);
    const float* px = static_cast<const float*>(readback.mapped);
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x)
        for (int ch = 0; ch < 4; ++ch) img.at(x, y, ch) = px[(static_cast<size_t>(y) * kSize + x) * 4 + ch];
    return img;
  };
  const Image<float> fmf_img = render(0);
  const Image<float> bsvtf_img = render(1);

  expect_engine_images_match("Vulkan", m, params, vt, fmf_img, bsvtf_img);

  vkDeviceWaitIdle(e.device);
  vkDestroyDescriptorPool(e.device, dpool, nullptr);
  vkDestroyPipeline(e.device, pipeline, nullptr);
  vkDestroyPipelineLayout(e.device, layout, nullptr);
  for (VkDescriptorSetLayout l : set_layouts) vkDestroyDescriptorSetLayout(e.device, l, nullptr);
}
