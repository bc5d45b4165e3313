// btflod sample — headless Vulkan 1.3 backend: device, init, FMF/BSVTF materials, tile and page-
// table uploads, frames, feedback ring, colour readback. See vk_internal.hpp.
#include "vk_internal.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

namespace btflod::samples::vk_detail {

VkBackend::~VkBackend() {
  if (vk_.device) {
    vkDeviceWaitIdle(vk_.device);
    for (VkMesh& m : meshes_) {
      destroy(m.vertices);
      destroy(m.indices);
    }
    for (VkMaterial& m : materials_) destroy_material(m);
    for (VkPipelineLayout l : rep_pipeline_layout_) vkDestroyPipelineLayout(vk_.device, l, nullptr);
    for (VkDescriptorSetLayout l : rep_set_layout_) vkDestroyDescriptorSetLayout(vk_.device, l, nullptr);
    for (FrameContext& c : contexts_) {
      destroy(c.staging);
      vkDestroyFence(vk_.device, c.fence, nullptr);
    }
    for (FeedbackSlot& s : ring_) destroy(s.buffer);
    destroy(color_readback_);
    destroy(ubo_all_);
    destroy_targets();
    for (Texture* t : {&page_table_, &dummy_float_, &dummy_uint_}) destroy(*t);
    for (VkCachePool& p : pools_) destroy(p);
    for (VkPipeline p : {fmf_, feedback_}) vkDestroyPipeline(vk_.device, p, nullptr);
    vkDestroyPipelineLayout(vk_.device, pipeline_layout_, nullptr);
    vkDestroyDescriptorPool(vk_.device, descriptor_pool_, nullptr);
    vkDestroyDescriptorSetLayout(vk_.device, set_layout_, nullptr);
    for (VkSampler s : {nearest_, linear_clamp_, linear_repeat_}) vkDestroySampler(vk_.device, s, nullptr);
    vkDestroyCommandPool(vk_.device, pool_, nullptr);
    vkDestroyCommandPool(vk_.device, one_shot_pool_, nullptr);
    vkDestroyDevice(vk_.device, nullptr);
  }
  if (vk_.instance) vkDestroyInstance(vk_.instance, nullptr);
}

VoidResult create_vk13_device(const char* app_name, VkDeviceContext& out) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = app_name;
  app.apiVersion = VK_API_VERSION_1_3;
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  BTFLOD_VK_CHECK(vkCreateInstance(&ici, nullptr, &out.instance), "vkCreateInstance (no Vulkan driver?)");
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(out.instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(out.instance, &count, devices.data());
  for (VkPhysicalDevice d : devices) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(d, &props);
    if (props.apiVersion < VK_API_VERSION_1_3) continue;
    uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(d, &qn, nullptr);
    std::vector<VkQueueFamilyProperties> qs(qn);
    vkGetPhysicalDeviceQueueFamilyProperties(d, &qn, qs.data());
    for (uint32_t q = 0; q < qn; ++q)
      if (qs[q].queueFlags & VK_QUEUE_GRAPHICS_BIT) {
        out.physical = d;
        out.queue_family = q;
        out.properties = props;
        break;
      }
    if (out.physical) break;
  }
  if (!out.physical)
    return make_error(Status::unsupported, "Vulkan: no 1.3 device with a graphics queue among %u", count);
  vkGetPhysicalDeviceMemoryProperties(out.physical, &out.memory);
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = out.queue_family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.dynamicRendering = VK_TRUE;
  VkPhysicalDeviceFeatures supported{};
  vkGetPhysicalDeviceFeatures(out.physical, &supported);
  VkPhysicalDeviceFeatures enabled{};
  enabled.textureCompressionBC = supported.textureCompressionBC;  // a bc5_affine cache (BC5_UNORM)
  out.texture_compression_bc = supported.textureCompressionBC == VK_TRUE;
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &f13;
  dci.pEnabledFeatures = &enabled;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  BTFLOD_VK_CHECK(vkCreateDevice(out.physical, &dci, nullptr, &out.device), "vkCreateDevice");
  vkGetDeviceQueue(out.device, out.queue_family, 0, &out.queue);
  return {};
}

VoidResult VkBackend::create_device() {
  if (VoidResult created = create_vk13_device("btflod", vk_); !created) return created;
  const VkPhysicalDeviceProperties& props = vk_.properties;
  name_ = std::string("Vulkan ") + std::to_string(VK_API_VERSION_MAJOR(props.apiVersion)) + "." +
          std::to_string(VK_API_VERSION_MINOR(props.apiVersion)) + " (" + props.deviceName + ")" +
          (options_.hlsl_programs ? ", HLSL programs" : "");
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = vk_.queue_family;
  BTFLOD_VK_CHECK(vkCreateCommandPool(vk_.device, &pci, nullptr, &pool_), "vkCreateCommandPool");
  pci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;  // set-up and blocking readback command buffers
  BTFLOD_VK_CHECK(vkCreateCommandPool(vk_.device, &pci, nullptr, &one_shot_pool_), "vkCreateCommandPool");
  return {};
}

VoidResult VkBackend::init(const ShaderConfig& config, uint32_t virtual_texture_count) {
  if (VoidResult v = validate_shader_config(config); !v) return v;
  if (virtual_texture_count == 0 || virtual_texture_count > vk_.properties.limits.maxImageArrayLayers)
    return make_error(Status::invalid_argument, "Vulkan: %u virtual textures, expected 1..%u", virtual_texture_count,
                      vk_.properties.limits.maxImageArrayLayers);
  const VirtualTextureConfig& vt = config.vt;
  if ((1u << vt.finest_level) > vk_.properties.limits.maxImageDimension2D)
    return make_error(Status::unsupported, "Vulkan: page table 2^%u exceeds the device limits", vt.finest_level);
  config_ = config;
  vt_layers_ = virtual_texture_count;
  if (VoidResult r = create_layout(); !r) return r;
  const ShaderProgram programs[2] = {ShaderProgram::fmf, ShaderProgram::feedback};
  VkPipeline* out[2] = {&fmf_, &feedback_};
  for (int i = 0; i < 2; ++i) {
    Result<VkPipeline> p = create_program_pipeline(programs[i], config);
    if (!p) return p.error();
    *out[i] = *p;
  }
  pools_.emplace_back();
  if (VoidResult r = create_pool(config, pools_.back()); !r) return r;
  // Page table (GENERAL layout, cleared to 0: entry 0 = slot 0 at level 0).
  if (VoidResult r = create_texture(page_table_, VK_FORMAT_R32_UINT, 1u << vt.finest_level, 1u << vt.finest_level,
                                    virtual_texture_count, vt.finest_level + 1);
      !r)
    return r;
  if (VoidResult r = create_texture(dummy_float_, VK_FORMAT_R32G32B32A32_SFLOAT, 1, 1, 1, 1); !r) return r;
  if (VoidResult r = create_texture(dummy_uint_, VK_FORMAT_R32G32B32A32_UINT, 1, 1, 1, 1); !r) return r;
  {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    if (VoidResult r = begin_one_shot(cmd); !r) return r;
    for (Texture* t : {&page_table_, &dummy_float_, &dummy_uint_}) {
      VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, t->mips, 0, t->layers};
      VkClearColorValue zero{};  // all-zero bits: 0.0f and 0u alike
      vkCmdClearColorImage(cmd, t->image, VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    }
    if (VoidResult r = end_one_shot(cmd); !r) return r;
  }
  // Frame contexts, feedback ring, the descriptor set used by feedback draws.
  contexts_.resize(options_.frames_in_flight);
  for (FrameContext& c : contexts_) {
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = pool_;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    BTFLOD_VK_CHECK(vkAllocateCommandBuffers(vk_.device, &ai, &c.cmd), "vkAllocateCommandBuffers");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    BTFLOD_VK_CHECK(vkCreateFence(vk_.device, &fci, nullptr, &c.fence), "vkCreateFence");
    if (VoidResult r = create_buffer(c.staging, options_.staging_bytes_per_frame, VK_BUFFER_USAGE_TRANSFER_SRC_BIT); !r)
      return r;
  }
  ring_.resize(options_.feedback_ring_size);
  if (Result<VkDescriptorSet> s = allocate_set(nullptr); s)
    feedback_set_ = *s;
  else
    return s.error();
  initialised_ = true;
  return {};
}

Result<VkPipeline> VkBackend::create_program_pipeline(ShaderProgram program, const ShaderConfig& config) {
  Result<GlslProgramSource> src = options_.hlsl_programs ? generate_hlsl_program(program, config)
                                                         : generate_program(program, GlslTarget::vulkan450, config);
  if (!src) return src.error();
  return create_pipeline(
      *src, shader_program_name(program),
      program == ShaderProgram::feedback ? VK_FORMAT_R32_UINT : VK_FORMAT_R32G32B32A32_SFLOAT, VK_NULL_HANDLE,
      program == ShaderProgram::bsvtf_feedback ? VK_FORMAT_R32_UINT : VK_FORMAT_UNDEFINED, options_.hlsl_programs);
}

void VkBackend::destroy(VkCachePool& pool) {
  destroy(pool.cache);
  destroy(pool.slot_map);
  for (VkPipeline p : {pool.bsvtf, pool.bsvtf_feedback}) vkDestroyPipeline(vk_.device, p, nullptr);
  pool.bsvtf = pool.bsvtf_feedback = VK_NULL_HANDLE;
}

Result<uint32_t> VkBackend::add_cache_pool(const CacheConfig& cache) {
  if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: add_cache_pool before init");
  if (pools_.size() >= kMaxCachePools)
    return make_error(Status::invalid_argument, "Vulkan: %zu cache pools already, at most %u", pools_.size(),
                      kMaxCachePools);
  ShaderConfig c = config_;
  static_cast<CacheConfig&>(c.vt) = cache;
  if (VoidResult v = validate_shader_config(c); !v) return v.error();
  VkCachePool pool;
  if (VoidResult r = create_pool(c, pool); !r) {
    destroy(pool);
    return r.error();
  }
  pools_.push_back(pool);
  return static_cast<uint32_t>(pools_.size() - 1);
}

VoidResult VkBackend::create_pool(const ShaderConfig& config, VkCachePool& pool) {
  const VirtualTextureConfig& vt = config.vt;
  pool.vt = vt;
  if (vt.cache_width() > vk_.properties.limits.maxImageDimension2D ||
      vt.cache_height() > vk_.properties.limits.maxImageDimension2D ||
      vt.cache_layers * (vt.format == CacheFormat::bc5_affine ? 2u : 1u) > vk_.properties.limits.maxImageArrayLayers)
    return make_error(Status::unsupported, "Vulkan: cache %u×%u×%u exceeds the device limits", vt.cache_width(),
                      vt.cache_height(), vt.cache_layers);
  Result<VkPipeline> bsvtf = create_program_pipeline(ShaderProgram::bsvtf, config);
  if (!bsvtf) return bsvtf.error();
  pool.bsvtf = *bsvtf;
  Result<VkPipeline> words = create_program_pipeline(ShaderProgram::bsvtf_feedback, config);
  if (!words) return words.error();
  pool.bsvtf_feedback = *words;
  Texture& cache_tex = pool.cache;
  Texture& map_tex = pool.slot_map;
  // Cache (GENERAL layout, cleared to 0).
  const bool affine = cache_format_has_slot_map(vt.format);
  const bool bc5 = vt.format == CacheFormat::bc5_affine;
  if (bc5) {
    if (!vk_.texture_compression_bc)
      return make_error(Status::unsupported,
                        "Vulkan: a bc5_affine cache needs the textureCompressionBC feature, which %s lacks",
                        vk_.properties.deviceName);
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(vk_.physical, VK_FORMAT_BC5_UNORM_BLOCK, &fp);
    if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT))
      return make_error(Status::unsupported, "Vulkan: %s cannot filter VK_FORMAT_BC5_UNORM_BLOCK linearly",
                        vk_.properties.deviceName);
  }
  // bc5_affine: two BC5 planes per cache layer, plane p of layer L at array layer 2L + p
  // (runtime/vt/cache_bc5.hpp; the shaders read both).
  if (VoidResult r = create_texture(cache_tex,
                                    bc5                                      ? VK_FORMAT_BC5_UNORM_BLOCK
                                    : vt.format == CacheFormat::rgba8_affine ? VK_FORMAT_R8G8B8A8_UNORM
                                                                             : VK_FORMAT_R16G16B16A16_SFLOAT,
                                    vt.cache_width(), vt.cache_height(), vt.cache_layers * (bc5 ? 2 : 1), 1);
      !r)
    return r;
  if (bc5) {  // vkCmdClearColorImage takes no compressed image: all-zero blocks decode to 0
    const std::vector<uint8_t> zero_blocks(static_cast<size_t>(vt.cache_width()) * vt.cache_height() * 2 *
                                           vt.cache_layers);
    if (VoidResult r = upload_texture(cache_tex, {zero_blocks.data()}, 1); !r) return r;  // 1 byte a texel
  }
  // rgba8_affine: one RGBA32UI texel per slot (runtime/vt/cache_format.hpp); otherwise a 1×1 stand-in
  // the rgba16f programs never read. A 2D view: the shaders declare a usampler2D.
  if (VoidResult r = create_texture(map_tex, VK_FORMAT_R32G32B32A32_UINT, affine ? cache_slot_map_width(vt) : 1,
                                    affine ? cache_slot_map_height(vt) : 1, 1, 1, 0, false);
      !r)
    return r;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (VoidResult r = begin_one_shot(cmd); !r) return r;
  for (Texture* t : {&cache_tex, &map_tex}) {
    if (t == &cache_tex && bc5) continue;  // filled with zero blocks above
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, t->mips, 0, t->layers};
    VkClearColorValue zero{};  // all-zero bits: 0.0f and 0u alike
    vkCmdClearColorImage(cmd, t->image, VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
  }
  return end_one_shot(cmd);
}

Result<MeshHandle> VkBackend::create_mesh(const MeshData& mesh) {
  if (VoidResult v = validate_mesh(mesh); !v) return v.error();
  VkMesh m;
  if (VoidResult r = create_buffer(m.vertices, mesh.vertices.size_bytes(), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT); !r)
    return r.error();
  if (VoidResult r = create_buffer(m.indices, mesh.indices.size_bytes(), VK_BUFFER_USAGE_INDEX_BUFFER_BIT); !r) {
    destroy(m.vertices);
    return r.error();
  }
  std::memcpy(m.vertices.mapped, mesh.vertices.data(), mesh.vertices.size_bytes());
  std::memcpy(m.indices.mapped, mesh.indices.data(), mesh.indices.size_bytes());
  m.index_count = static_cast<uint32_t>(mesh.indices.size());
  meshes_.push_back(m);
  return MeshHandle{static_cast<uint32_t>(meshes_.size())};
}

Result<MaterialHandle> VkBackend::create_material(const FmfMaterialData& data) {
  if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: create_material before init");
  if (VoidResult v = validate_material(data, config_); !v) return v.error();
  if (data.cache_pool >= pools_.size())
    return make_error(Status::invalid_argument, "Vulkan: the material names cache pool %u of %zu", data.cache_pool,
                      pools_.size());
  VkMaterial m;
  m.pool = data.cache_pool;
  m.light_count = data.light_count;
  m.view_count = data.view_count;
  m.components = data.components;
  const std::vector<float> u = pack_eigen_abrdfs_rgba(data);
  std::vector<uint32_t> index;
  std::vector<float> weight;
  pack_angular_tables_rgba(data.angular, index, weight);
  const uint32_t res = data.angular.resolution;
  VoidResult r = create_texture(m.eigen_abrdfs, VK_FORMAT_R32G32B32A32_SFLOAT, data.light_count, data.view_count,
                                data.components, 1);
  if (r) r = upload_texture(m.eigen_abrdfs, {u.data()}, 16);
  if (r) r = create_texture(m.angular_index, VK_FORMAT_R32G32B32A32_UINT, res, res, 2, 1);
  if (r) r = upload_texture(m.angular_index, {index.data()}, 16);
  if (r) r = create_texture(m.angular_weight, VK_FORMAT_R32G32B32A32_SFLOAT, res, res, 2, 1);
  if (r) r = upload_texture(m.angular_weight, {weight.data()}, 16);
  if (r && !data.eigen_textures.empty()) {
    // Mip chain on the CPU (2×2 box, clamped at odd edges), like a GPU mipmap generator.
    std::vector<std::vector<float>> levels{pack_eigen_textures_rgba(data.eigen_textures)};
    const uint32_t groups = (data.components + 3) / 4;  // the material's C_m, not the programs' C
    uint32_t w = static_cast<uint32_t>(data.eigen_textures.width()),
             h = static_cast<uint32_t>(data.eigen_textures.height());
    std::vector<std::pair<uint32_t, uint32_t>> sizes{{w, h}};
    while (data.mipmaps && (w > 1 || h > 1)) {
      const uint32_t nw = std::max(w / 2, 1u), nh = std::max(h / 2, 1u);
      std::vector<float> next(static_cast<size_t>(nw) * nh * 4 * groups);
      const std::vector<float>& prev = levels.back();
      for (uint32_t g = 0; g < groups; ++g)
        for (uint32_t y = 0; y < nh; ++y)
          for (uint32_t x = 0; x < nw; ++x)
            for (uint32_t k = 0; k < 4; ++k) {
              float sum = 0;
              for (uint32_t dy = 0; dy < 2; ++dy)
                for (uint32_t dx = 0; dx < 2; ++dx) {
                  const uint32_t sx = std::min(2 * x + dx, w - 1), sy = std::min(2 * y + dy, h - 1);
                  sum += prev[((static_cast<size_t>(g) * h + sy) * w + sx) * 4 + k];
                }
              next[((static_cast<size_t>(g) * nh + y) * nw + x) * 4 + k] = 0.25f * sum;
            }
      levels.push_back(std::move(next));
      w = nw;
      h = nh;
      sizes.emplace_back(w, h);
    }
    r = create_texture(m.eigen_textures, VK_FORMAT_R32G32B32A32_SFLOAT, sizes[0].first, sizes[0].second, groups,
                       static_cast<uint32_t>(levels.size()));
    std::vector<const void*> ptrs;
    for (const auto& l : levels) ptrs.push_back(l.data());
    if (r) r = upload_texture(m.eigen_textures, ptrs, 16);
  }
  if (!r) {
    destroy_material(m);
    return r.error();
  }
  Result<VkDescriptorSet> set = allocate_set(&m);
  if (!set) {
    destroy_material(m);
    return set.error();
  }
  m.set = *set;
  materials_.push_back(m);
  return MaterialHandle{static_cast<uint32_t>(materials_.size())};
}

Status VkBackend::destroy_material(MaterialHandle material) {
  if (in_frame_ || material.id == 0 || material.id > materials_.size() || !materials_[material.id - 1].live)
    return Status::invalid_argument;
  // Uploads recorded since the last frame may still write its textures: submit them, then wait
  // until no command buffer reads the material (set-up time).
  if (recording_ && !submit_context()) return Status::io_error;
  if (wait_idle() != Status::success) return Status::io_error;
  VkMaterial& m = materials_[material.id - 1];
  if (m.set) vkFreeDescriptorSets(vk_.device, descriptor_pool_, 1, &m.set);
  destroy_material(m);
  m = VkMaterial{};
  m.live = false;
  return Status::success;
}

Status VkBackend::upload_tiles(std::span<const TileUpload> tiles) noexcept {
  if (!initialised_) return Status::invalid_argument;
  // Each tile's staging bytes in its pool's format; each map copy starts 16-byte aligned (an
  // RGBA32UI texel): up to 15 bytes of padding per tile.
  size_t staging = 0;
  for (const TileUpload& t : tiles) {
    if (t.pool >= pools_.size() || check_tile_upload(t, pools_[t.pool].vt) != Status::success)
      return Status::invalid_argument;
    const VirtualTextureConfig& vt = pools_[t.pool].vt;
    staging += size_t{vt.padded_tile_size()} * vt.padded_tile_size() * vt.texel_bytes() +
               (cache_format_has_slot_map(vt.format) ? 16 + 15 : 0);
  }
  FrameContext& c = open_context();
  if (c.staging_offset + staging > c.staging.size) return Status::insufficient_space;
  for (const TileUpload& t : tiles) {
    const VkCachePool& pool = pools_[t.pool];
    const VirtualTextureConfig& vt = pool.vt;
    const size_t padded = vt.padded_tile_size();
    const bool affine = cache_format_has_slot_map(vt.format);
    const bool bc5 = vt.format == CacheFormat::bc5_affine;
    const size_t bytes = padded * padded * vt.texel_bytes();  // bc5_affine: both planes
    const size_t map_bytes = affine ? 16 : 0;                 // pack_cache_slot_map
    if (affine) {
      c.staging_offset = (c.staging_offset + 15) & ~VkDeviceSize{15};
      const std::array<uint32_t, 4> packed = pack_cache_slot_map(t.map);
      std::memcpy(static_cast<char*>(c.staging.mapped) + c.staging_offset, packed.data(), map_bytes);
      const CacheSlotMapTexel m = cache_slot_map_texel(vt, t.slot);
      VkBufferImageCopy region{};
      region.bufferOffset = c.staging_offset;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageOffset = {static_cast<int32_t>(m.x), static_cast<int32_t>(m.y), 0};
      region.imageExtent = {1, 1, 1};
      vkCmdCopyBufferToImage(c.cmd, c.staging.buffer, pool.slot_map.image, VK_IMAGE_LAYOUT_GENERAL, 1, &region);
      c.staging_offset += map_bytes;
    }
    std::memcpy(static_cast<char*>(c.staging.mapped) + c.staging_offset,
                bc5      ? static_cast<const void*>(t.bc5.data())
                : affine ? static_cast<const void*>(t.unorm8.data())
                         : t.texels.data(),
                bytes);
    const SlotPlacement p = slot_placement(vt, t.slot);
    // bc5_affine: one copy per plane (the blocks of plane p, bytes / 2 of them, to array layer
    // 2L + p); the offsets stay 16-byte aligned (the map copy above, whole blocks).
    const uint32_t planes = bc5 ? 2 : 1;
    VkBufferImageCopy regions[2]{};
    for (uint32_t plane = 0; plane < planes; ++plane) {
      VkBufferImageCopy& region = regions[plane];
      region.bufferOffset = c.staging_offset + plane * (bytes / planes);
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, bc5 ? 2 * p.layer + plane : p.layer, 1};
      region.imageOffset = {static_cast<int32_t>(p.x), static_cast<int32_t>(p.y), 0};
      region.imageExtent = {static_cast<uint32_t>(padded), static_cast<uint32_t>(padded), 1};
    }
    vkCmdCopyBufferToImage(c.cmd, c.staging.buffer, pool.cache.image, VK_IMAGE_LAYOUT_GENERAL, planes, regions);
    c.staging_offset += bytes;
  }
  full_barrier(c.cmd);
  return Status::success;
}

Status VkBackend::upload_u_packets(MaterialHandle material, std::span<const UPacketUpload> packets) noexcept {
  if (!initialised_ || material.id == 0 || material.id > materials_.size()) return Status::invalid_argument;
  const VkMaterial& m = materials_[material.id - 1];
  if (!m.live || m.program != ShaderProgram::fmf || m.components == 0) return Status::invalid_argument;
  const size_t plane = size_t{m.light_count} * m.view_count * 4 * sizeof(float);
  size_t need = 0;
  for (const UPacketUpload& p : packets) {
    if (check_u_packet(p, m.light_count, m.view_count, m.components) != Status::success)
      return Status::invalid_argument;
    need += plane * std::min(4u, m.components - 4 * p.packet);
  }
  FrameContext& c = open_context();
  const VkDeviceSize start = (c.staging_offset + 15) & ~VkDeviceSize{15};
  if (start + need > c.staging.size) return Status::insufficient_space;
  c.staging_offset = start;
  for (const UPacketUpload& p : packets) {
    // Converted straight into the frame's staging memory (eigen_abrdfs is RGBA32F).
    const size_t room = static_cast<size_t>(c.staging.size - c.staging_offset) / sizeof(float);
    float* dst = reinterpret_cast<float*>(static_cast<char*>(c.staging.mapped) + c.staging_offset);
    const uint32_t n =
        u_packet_to_rgba_layers(p, m.light_count, m.view_count, m.components, std::span<float>(dst, room));
    VkBufferImageCopy region{};
    region.bufferOffset = c.staging_offset;
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 4 * p.packet, n};
    region.imageExtent = {m.light_count, m.view_count, 1};
    vkCmdCopyBufferToImage(c.cmd, c.staging.buffer, m.eigen_abrdfs.image, VK_IMAGE_LAYOUT_GENERAL, 1, &region);
    c.staging_offset += plane * n;
  }
  full_barrier(c.cmd);
  return Status::success;
}

Status VkBackend::apply_page_table_writes(std::span<const PageTableWrite> writes) noexcept {
  if (!initialised_) return Status::invalid_argument;
  if (Status s = check_page_table_writes(writes, vt_layers_, config_.vt.finest_level); s != Status::success) return s;
  FrameContext& c = open_context();
  const VkDeviceSize start = (c.staging_offset + 3) & ~VkDeviceSize{3};
  if (start + 4 * writes.size() > c.staging.size) return Status::insufficient_space;
  c.staging_offset = start;
  VkBufferImageCopy regions[64];
  uint32_t n = 0;
  for (const PageTableWrite& w : writes) {
    std::memcpy(static_cast<char*>(c.staging.mapped) + c.staging_offset, &w.entry, 4);
    VkBufferImageCopy& r = regions[n++];
    r = VkBufferImageCopy{};
    r.bufferOffset = c.staging_offset;
    r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, w.page_mip, w.tile.texture, 1};
    r.imageOffset = {static_cast<int32_t>(w.tile.x), static_cast<int32_t>(w.tile.y), 0};
    r.imageExtent = {1, 1, 1};
    c.staging_offset += 4;
    if (n == 64) {
      vkCmdCopyBufferToImage(c.cmd, c.staging.buffer, page_table_.image, VK_IMAGE_LAYOUT_GENERAL, n, regions);
      n = 0;
    }
  }
  if (n) vkCmdCopyBufferToImage(c.cmd, c.staging.buffer, page_table_.image, VK_IMAGE_LAYOUT_GENERAL, n, regions);
  full_barrier(c.cmd);
  return Status::success;
}

Status VkBackend::begin_frame(const FrameDesc& frame) noexcept {
  if (!initialised_ || frame.width == 0 || frame.height == 0 || frame.feedback_width == 0 ||
      frame.feedback_height == 0 || frame.width > vk_.properties.limits.maxImageDimension2D ||
      frame.height > vk_.properties.limits.maxImageDimension2D ||
      frame.feedback_sample_x >= frame.feedback_block_width() ||
      frame.feedback_sample_y >= frame.feedback_block_height())
    return Status::invalid_argument;
  if (frame.width != frame_.width || frame.height != frame_.height || frame.feedback_width != frame_.feedback_width ||
      frame.feedback_height != frame_.feedback_height || !color_.image) {
    vkDeviceWaitIdle(vk_.device);  // size change: set-up work
    destroy_targets();
    frame_ = frame;
    if (!create_targets()) return Status::unsupported;
  }
  frame_ = frame;
  FrameContext& c = open_context();
  // Clear through rendering load ops (one empty pass per target).
  VkClearValue color_clear{};
  std::memcpy(color_clear.color.float32, frame.clear_color, sizeof(color_clear.color.float32));
  VkClearValue feedback_clear{};
  feedback_clear.color.uint32[0] = config_.vt.feedback.empty_word;
  clear_pass(c.cmd, color_, color_depth_, color_clear, frame.width, frame.height);
  clear_pass(c.cmd, feedback_color_, feedback_depth_, feedback_clear, frame.feedback_width, frame.feedback_height);
  full_barrier(c.cmd);
  feedback_drawn_ = feedback_stored_ = false;
  in_frame_ = true;
  return Status::success;
}

Status VkBackend::draw(ShaderProgram program, MeshHandle mesh, MaterialHandle material,
                       const ShaderParams& params) noexcept {
  if (!in_frame_ || mesh.id == 0 || mesh.id > meshes_.size() || material.id == 0 || material.id > materials_.size())
    return Status::invalid_argument;
  const VkMaterial& m = materials_[material.id - 1];
  if (!m.live) return Status::invalid_argument;
  if (m.program != ShaderProgram::fmf) {  // laplacian / lpca / pca_views: the material's own pipeline
    if (m.program != program) return Status::invalid_argument;
    return record_draw(m.pipeline, m.set, meshes_[mesh.id - 1], params, color_, color_depth_, frame_.width,
                       frame_.height, rep_pipeline_layout_[rep_kind(program)]);
  }
  VkPipeline pipeline = VK_NULL_HANDLE;
  if (program == ShaderProgram::fmf && m.eigen_textures.image)
    pipeline = fmf_;
  else if (program == ShaderProgram::bsvtf)
    pipeline = pools_[m.pool].bsvtf;  // its pool's tile size and format; its set binds the pool's cache
  else if (program == ShaderProgram::bsvtf_feedback)
    pipeline = pools_[m.pool].bsvtf_feedback;
  else
    return Status::invalid_argument;
  const ShaderParams material_params = params_for_material(params, m.components);
  if (program != ShaderProgram::bsvtf_feedback)
    return record_draw(pipeline, m.set, meshes_[mesh.id - 1], material_params, color_, color_depth_, frame_.width,
                       frame_.height);
  // Colour and every pixel's feedback word (second colour target). The word target is cleared
  // by the frame's first such draw only: frames without one never touch it.
  if (!feedback_stored_) {
    FrameContext& c = open_context();
    VkClearColorValue empty{};
    empty.uint32[0] = config_.vt.feedback.empty_word;
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(c.cmd, feedback_full_.image, VK_IMAGE_LAYOUT_GENERAL, &empty, 1, &range);
    full_barrier(c.cmd);
  }
  const Status s = record_draw(pipeline, m.set, meshes_[mesh.id - 1], material_params, color_, color_depth_,
                               frame_.width, frame_.height, VK_NULL_HANDLE, &feedback_full_);
  if (s == Status::success) feedback_drawn_ = feedback_stored_ = true;
  return s;
}

Status VkBackend::draw_feedback(MeshHandle mesh, const ShaderParams& params) noexcept {
  if (!in_frame_ || mesh.id == 0 || mesh.id > meshes_.size()) return Status::invalid_argument;
  const Status s = record_draw(feedback_, feedback_set_, meshes_[mesh.id - 1], params, feedback_color_, feedback_depth_,
                               frame_.feedback_width, frame_.feedback_height);
  if (s == Status::success) feedback_drawn_ = true;
  return s;
}

Status VkBackend::end_frame() noexcept {
  if (!in_frame_) return Status::invalid_argument;
  FrameContext& c = open_context();
  const uint64_t serial = next_serial_;
  if (feedback_drawn_) {
    FeedbackSlot* slot = nullptr;
    for (FeedbackSlot& s : ring_)
      if (!s.pending) {
        slot = &s;
        break;
      }
    if (!slot) {  // every buffer holds an unconsumed readback: drop the oldest, never wait
      slot = &*std::min_element(ring_.begin(), ring_.end(),
                                [](const FeedbackSlot& a, const FeedbackSlot& b) { return a.frame < b.frame; });
      slot->pending = false;
      ++dropped_;
    }
    // A bsvtf_feedback frame copies every pixel's word (subsampled in poll_feedback), any other
    // the feedback target.
    const uint32_t w = feedback_stored_ ? frame_.width : frame_.feedback_width;
    const uint32_t h = feedback_stored_ ? frame_.height : frame_.feedback_height;
    const VkDeviceSize bytes = VkDeviceSize{w} * h * 4;
    if (slot->buffer.size < bytes) {
      // Grows only when the feedback size grows; a dropped slot may still be read by the GPU.
      vkDeviceWaitIdle(vk_.device);
      destroy(slot->buffer);
      if (!create_buffer(slot->buffer, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT)) return Status::unsupported;
    }
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {w, h, 1};
    vkCmdCopyImageToBuffer(c.cmd, (feedback_stored_ ? feedback_full_ : feedback_color_).image, VK_IMAGE_LAYOUT_GENERAL,
                           slot->buffer.buffer, 1, &region);
    slot->full = feedback_stored_;
    slot->desc = frame_;
    slot->serial = serial;
    slot->frame = frame_counter_;
    slot->width = frame_.feedback_width;
    slot->height = frame_.feedback_height;
    slot->pending = true;
  }
  full_barrier(c.cmd);
  in_frame_ = false;
  ++frame_counter_;
  return submit_context() ? Status::success : Status::io_error;
}

bool VkBackend::poll_feedback(FeedbackFrame& out) noexcept {
  update_completed();
  FeedbackSlot* oldest = nullptr;
  for (FeedbackSlot& s : ring_)
    if (s.pending && (!oldest || s.frame < oldest->frame)) oldest = &s;
  if (!oldest || oldest->serial > completed_serial_) return false;
  const size_t n = static_cast<size_t>(oldest->width) * oldest->height;
  if (readback_.size() < n) readback_.resize(n);  // grows to the largest feedback size once
  if (oldest->full) {                             // the words of every pixel, row 0 = top (flipped viewport)
    const size_t full = static_cast<size_t>(oldest->desc.width) * oldest->desc.height;
    subsample_feedback(std::span<const uint32_t>(static_cast<const uint32_t*>(oldest->buffer.mapped), full), false,
                       oldest->desc, config_.vt.feedback.empty_word, std::span<uint32_t>(readback_.data(), n));
  } else {
    std::memcpy(readback_.data(), oldest->buffer.mapped, n * 4);  // row 0 = top (flipped viewport)
  }
  out.frame = oldest->frame;
  out.width = oldest->width;
  out.height = oldest->height;
  out.words = std::span<const uint32_t>(readback_.data(), n);
  oldest->pending = false;
  return true;
}

Status VkBackend::read_color(ImageView<float> out) noexcept {
  if (!color_.image || out.width() != static_cast<int>(frame_.width) ||
      out.height() != static_cast<int>(frame_.height) || out.channels() != 4)
    return Status::invalid_argument;
  if (in_frame_) return Status::invalid_argument;  // end_frame() first
  const VkDeviceSize bytes = VkDeviceSize{frame_.width} * frame_.height * 16;
  if (color_readback_.size < bytes) {
    destroy(color_readback_);
    if (!create_buffer(color_readback_, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT)) return Status::unsupported;
  }
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (!begin_one_shot(cmd)) return Status::io_error;
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {frame_.width, frame_.height, 1};
  vkCmdCopyImageToBuffer(cmd, color_.image, VK_IMAGE_LAYOUT_GENERAL, color_readback_.buffer, 1, &region);
  full_barrier(cmd);
  if (!end_one_shot(cmd)) return Status::io_error;
  const float* src = static_cast<const float*>(color_readback_.mapped);
  for (uint32_t y = 0; y < frame_.height; ++y)
    for (uint32_t x = 0; x < frame_.width; ++x)
      for (int k = 0; k < 4; ++k)
        out.at(static_cast<int>(x), static_cast<int>(y), k) =
            src[(static_cast<size_t>(y) * frame_.width + x) * 4 + static_cast<size_t>(k)];
  return Status::success;
}

Status VkBackend::wait_idle() noexcept {
  if (vkQueueWaitIdle(vk_.queue) != VK_SUCCESS) return Status::io_error;
  completed_serial_ = next_serial_ - 1;
  return Status::success;
}

VoidResult VkBackend::create_shared_ubo() {
  // One host-visible buffer sliced per frame context and per draw (dynamic offsets).
  ubo_stride_ = (sizeof(ShaderParams) + vk_.properties.limits.minUniformBufferOffsetAlignment - 1) /
                vk_.properties.limits.minUniformBufferOffsetAlignment *
                vk_.properties.limits.minUniformBufferOffsetAlignment;
  return create_buffer(ubo_all_, ubo_stride_ * options_.max_draws_per_frame * options_.frames_in_flight,
                       VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
}

}  // namespace btflod::samples::vk_detail

namespace btflod::samples {

Result<std::unique_ptr<Backend>> create_vk_backend(const VkBackendOptions& options) {
  auto backend = std::make_unique<vk_detail::VkBackend>(options);
  if (VoidResult r = backend->create_device(); !r) return r.error();
  if (VoidResult r = backend->create_shared_ubo(); !r) return r.error();
  return std::unique_ptr<Backend>(std::move(backend));
}

}  // namespace btflod::samples
