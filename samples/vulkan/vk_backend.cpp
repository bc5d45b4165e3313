// btflod sample — headless Vulkan 1.3 backend. See vk_backend.hpp.
//
// Kept deliberately plain: one VkDeviceMemory per resource, every image in GENERAL layout,
// full memory barriers between phases, dynamic rendering (one begin/end per draw, load op
// LOAD; targets are cleared with vkCmdClear*Image in begin_frame). Per-frame data (uniform
// slices, upload staging) lives in a ring of frame contexts; feedback is copied into a ring of
// host-visible buffers whose completion is tracked by submission serials, polled via fences.
#include "vk_backend.hpp"

#include <vulkan/vulkan.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace btflod::samples {
namespace {

constexpr uint32_t kBindingCount = 7;  // ShaderBinding::params … page_table

struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
  VkDeviceSize size = 0;
};

struct Texture {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
  VkFormat format = VK_FORMAT_UNDEFINED;
  uint32_t width = 0, height = 0, layers = 0, mips = 0;
  uint32_t depth = 1;  ///< > 1: a 3D image (the lpca volume)
};

struct VkMesh {
  Buffer vertices, indices;
  uint32_t index_count = 0;
};

struct VkMaterial {
  Texture eigen_abrdfs, angular_index, angular_weight, eigen_textures;
  VkDescriptorSet set = VK_NULL_HANDLE;
  /// laplacian / lpca / pca_views materials: their program (fmf = an FMF material), textures
  /// and pipeline (generated with representation_config()).
  ShaderProgram program = ShaderProgram::fmf;
  Texture rep[6];
  VkPipeline pipeline = VK_NULL_HANDLE;
};

/// One texture of a representation material: where it binds, its shape and data (per mip).
struct RepTexture {
  ShaderBinding binding;
  VkFormat format;
  uint32_t width, height, layers, mips, depth;
  bool array_view;
  std::vector<const void*> data;
  uint32_t texel_bytes;
  bool linear;  ///< linear filtering (the lpca volume); else nearest
};

struct FrameContext {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  uint64_t serial = 0;  ///< submission serial; 0 = never submitted
  Buffer staging;
  VkDeviceSize ubo_offset = 0, staging_offset = 0;
};

struct FeedbackSlot {
  Buffer buffer;
  uint64_t serial = 0, frame = 0;
  uint32_t width = 0, height = 0;
  bool pending = false;
};

#define BTFLOD_VK_CHECK(expr, what)                                                                                  \
  do {                                                                                                               \
    const VkResult vk_result_ = (expr);                                                                              \
    if (vk_result_ != VK_SUCCESS)                                                                                    \
      return make_error(Status::unsupported, "Vulkan: %s failed (VkResult %d)", what, static_cast<int>(vk_result_)); \
  } while (0)

uint64_t fnv1a(const std::string& text, uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::vector<uint32_t> read_words(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.empty() || bytes.size() % 4 != 0) return {};
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  return words;
}

/// GLSL → SPIR-V with glslc (subprocess). Results are cached in the temp directory under a hash
/// of (glslc path, stage, source): the generated source is deterministic, so every later run
/// (and every test process) skips the ~0.4 s compile. Files are published with rename().
Result<std::vector<uint32_t>> compile_spirv(const std::string& source, const char* stage, const std::string& tag) {
  const std::string glslc = BTFLOD_GLSLC;
  if (glslc.empty()) return make_error(Status::unsupported, "Vulkan: glslc was not found at configure time");
  static std::atomic<unsigned> counter{0};
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  char hash[32];
  std::snprintf(hash, sizeof(hash), "%016llx",
                static_cast<unsigned long long>(fnv1a(source, fnv1a(glslc + "|" + stage + "|vulkan1.1"))));
  const std::string cached = (dir / ("btflod_spv_" + std::string(hash) + "." + stage + ".spv")).string();
  if (std::vector<uint32_t> words = read_words(cached); !words.empty() && words[0] == 0x07230203u) return words;
  const std::string base =
      (dir / ("btflod_vk_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" + tag)).string();
  const std::string src = base + "." + stage, spv = base + "." + stage + ".spv", log = base + ".log";
  {
    std::ofstream f(src, std::ios::binary);
    f << source;
    if (!f) return make_error(Status::io_error, "Vulkan: cannot write %s", src.c_str());
  }
  const std::string cmd =
      "\"" + glslc + "\" --target-env=vulkan1.1 -o \"" + spv + "\" \"" + src + "\" > \"" + log + "\" 2>&1";
  const int rc = std::system(cmd.c_str());
  std::vector<uint32_t> words = read_words(spv);
  std::ifstream lg(log);
  const std::string log_text((std::istreambuf_iterator<char>(lg)), std::istreambuf_iterator<char>());
  std::error_code ec;
  std::filesystem::remove(src, ec);
  std::filesystem::remove(log, ec);
  if (rc != 0 || words.empty()) {
    std::filesystem::remove(spv, ec);
    return make_error(Status::unsupported, "Vulkan: glslc failed on %s shader %s (exit %d): %s", stage, tag.c_str(), rc,
                      log_text.c_str());
  }
  std::filesystem::rename(spv, cached, ec);  // atomic publish; on failure just drop the file
  if (ec) std::filesystem::remove(spv, ec);
  return words;
}

class VkBackend final : public Backend {
 public:
  explicit VkBackend(const VkBackendOptions& o) : options_(o) {
    options_.feedback_ring_size = std::max<uint32_t>(o.feedback_ring_size, 1);
    options_.frames_in_flight = std::max<uint32_t>(o.frames_in_flight, 1);
    options_.max_draws_per_frame = std::max<uint32_t>(o.max_draws_per_frame, 1);
  }

  ~VkBackend() override {
    if (device_) {
      vkDeviceWaitIdle(device_);
      for (VkMesh& m : meshes_) {
        destroy(m.vertices);
        destroy(m.indices);
      }
      for (VkMaterial& m : materials_) destroy_material(m);
      for (VkPipelineLayout l : rep_pipeline_layout_) vkDestroyPipelineLayout(device_, l, nullptr);
      for (VkDescriptorSetLayout l : rep_set_layout_) vkDestroyDescriptorSetLayout(device_, l, nullptr);
      for (FrameContext& c : contexts_) {
        destroy(c.staging);
        vkDestroyFence(device_, c.fence, nullptr);
      }
      for (FeedbackSlot& s : ring_) destroy(s.buffer);
      destroy(color_readback_);
      destroy(ubo_all_);
      destroy_targets();
      for (Texture* t : {&cache_, &page_table_, &dummy_float_, &dummy_uint_}) destroy(*t);
      for (VkPipeline p : {fmf_, bsvtf_, feedback_}) vkDestroyPipeline(device_, p, nullptr);
      vkDestroyPipelineLayout(device_, pipeline_layout_, nullptr);
      vkDestroyDescriptorPool(device_, descriptor_pool_, nullptr);
      vkDestroyDescriptorSetLayout(device_, set_layout_, nullptr);
      for (VkSampler s : {nearest_, linear_clamp_, linear_repeat_}) vkDestroySampler(device_, s, nullptr);
      vkDestroyCommandPool(device_, pool_, nullptr);
      vkDestroyCommandPool(device_, one_shot_pool_, nullptr);
      vkDestroyDevice(device_, nullptr);
    }
    if (instance_) vkDestroyInstance(instance_, nullptr);
  }

  VoidResult create_device() {
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "btflod";
    app.apiVersion = VK_API_VERSION_1_3;
    VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ici.pApplicationInfo = &app;
    BTFLOD_VK_CHECK(vkCreateInstance(&ici, nullptr, &instance_), "vkCreateInstance (no Vulkan driver?)");
    uint32_t count = 0;
    vkEnumeratePhysicalDevices(instance_, &count, nullptr);
    std::vector<VkPhysicalDevice> devices(count);
    vkEnumeratePhysicalDevices(instance_, &count, devices.data());
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
          physical_ = d;
          queue_family_ = q;
          limits_ = props.limits;
          name_ = std::string("Vulkan ") + std::to_string(VK_API_VERSION_MAJOR(props.apiVersion)) + "." +
                  std::to_string(VK_API_VERSION_MINOR(props.apiVersion)) + " (" + props.deviceName + ")";
          break;
        }
      if (physical_) break;
    }
    if (!physical_)
      return make_error(Status::unsupported, "Vulkan: no 1.3 device with a graphics queue among %u", count);
    vkGetPhysicalDeviceMemoryProperties(physical_, &memory_props_);
    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qci.queueFamilyIndex = queue_family_;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    f13.dynamicRendering = VK_TRUE;
    VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    dci.pNext = &f13;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    BTFLOD_VK_CHECK(vkCreateDevice(physical_, &dci, nullptr, &device_), "vkCreateDevice");
    vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
    VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pci.queueFamilyIndex = queue_family_;
    BTFLOD_VK_CHECK(vkCreateCommandPool(device_, &pci, nullptr, &pool_), "vkCreateCommandPool");
    pci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;  // set-up and blocking readback command buffers
    BTFLOD_VK_CHECK(vkCreateCommandPool(device_, &pci, nullptr, &one_shot_pool_), "vkCreateCommandPool");
    return {};
  }

  const char* name() const noexcept override { return name_.c_str(); }

  VoidResult init(const ShaderConfig& config, uint32_t virtual_texture_count) override {
    if (VoidResult v = validate_shader_config(config); !v) return v;
    if (virtual_texture_count == 0 || virtual_texture_count > limits_.maxImageArrayLayers)
      return make_error(Status::invalid_argument, "Vulkan: %u virtual textures, expected 1..%u", virtual_texture_count,
                        limits_.maxImageArrayLayers);
    const VirtualTextureConfig& vt = config.vt;
    if (vt.cache_width() > limits_.maxImageDimension2D || vt.cache_height() > limits_.maxImageDimension2D ||
        vt.cache_layers > limits_.maxImageArrayLayers || (1u << vt.finest_level) > limits_.maxImageDimension2D)
      return make_error(Status::unsupported, "Vulkan: cache %u×%u×%u or page table 2^%u exceeds the device limits",
                        vt.cache_width(), vt.cache_height(), vt.cache_layers, vt.finest_level);
    config_ = config;
    vt_layers_ = virtual_texture_count;
    if (VoidResult r = create_layout(); !r) return r;
    const ShaderProgram programs[3] = {ShaderProgram::fmf, ShaderProgram::bsvtf, ShaderProgram::feedback};
    VkPipeline* out[3] = {&fmf_, &bsvtf_, &feedback_};
    for (int i = 0; i < 3; ++i) {
      Result<GlslProgramSource> src = generate_program(programs[i], GlslTarget::vulkan450, config);
      if (!src) return src.error();
      Result<VkPipeline> p =
          create_pipeline(*src, shader_program_name(programs[i]),
                          programs[i] == ShaderProgram::feedback ? VK_FORMAT_R32_UINT : VK_FORMAT_R32G32B32A32_SFLOAT);
      if (!p) return p.error();
      *out[i] = *p;
    }
    // Cache and page table (GENERAL layout, cleared to 0: entry 0 = slot 0 at level 0).
    if (VoidResult r = create_texture(cache_, VK_FORMAT_R16G16B16A16_SFLOAT, vt.cache_width(), vt.cache_height(),
                                      vt.cache_layers, 1);
        !r)
      return r;
    if (VoidResult r = create_texture(page_table_, VK_FORMAT_R32_UINT, 1u << vt.finest_level, 1u << vt.finest_level,
                                      virtual_texture_count, vt.finest_level + 1);
        !r)
      return r;
    if (VoidResult r = create_texture(dummy_float_, VK_FORMAT_R32G32B32A32_SFLOAT, 1, 1, 1, 1); !r) return r;
    if (VoidResult r = create_texture(dummy_uint_, VK_FORMAT_R32G32B32A32_UINT, 1, 1, 1, 1); !r) return r;
    {
      VkCommandBuffer cmd = VK_NULL_HANDLE;
      if (VoidResult r = begin_one_shot(cmd); !r) return r;
      for (Texture* t : {&cache_, &page_table_, &dummy_float_, &dummy_uint_}) {
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
      BTFLOD_VK_CHECK(vkAllocateCommandBuffers(device_, &ai, &c.cmd), "vkAllocateCommandBuffers");
      VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
      BTFLOD_VK_CHECK(vkCreateFence(device_, &fci, nullptr, &c.fence), "vkCreateFence");
      if (VoidResult r = create_buffer(c.staging, options_.staging_bytes_per_frame, VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
          !r)
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

  Result<MeshHandle> create_mesh(const MeshData& mesh) override {
    if (mesh.vertices.empty() || mesh.indices.empty() || mesh.indices.size() % 3 != 0)
      return make_error(Status::invalid_argument, "Vulkan: mesh with %zu vertices, %zu indices (need a triangle list)",
                        mesh.vertices.size(), mesh.indices.size());
    for (uint32_t i : mesh.indices)
      if (i >= mesh.vertices.size())
        return make_error(Status::invalid_argument, "Vulkan: mesh index %u ≥ %zu vertices", i, mesh.vertices.size());
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

  Result<MaterialHandle> create_material(const FmfMaterialData& data) override {
    if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: create_material before init");
    if (VoidResult v = validate_material(data, config_); !v) return v.error();
    VkMaterial m;
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
      const uint32_t groups = config_.component_groups();
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

  Result<MaterialHandle> create_laplacian_material(const LaplacianMaterialData& d) override {
    if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: create_laplacian_material before init");
    if (VoidResult v = validate_material(d, config_); !v) return v.error();
    const uint32_t groups = (d.components + 3) / 4;
    std::vector<const void*> weight_mips;  // mip k = pyramid level k (paper 001 §3.3)
    const float* w = d.weights.data();
    for (uint32_t k = 0; k <= d.max_level; ++k) {
      weight_mips.push_back(w);
      w += static_cast<size_t>(std::max(1u, d.width >> k)) * std::max(1u, d.height >> k) * groups * 4;
    }
    std::vector<uint32_t> index;
    std::vector<float> weight;
    pack_angular_tables_rgba(d.angular, index, weight);
    const uint32_t res = d.angular.resolution;
    const VkFormat f4 = VK_FORMAT_R32G32B32A32_SFLOAT;
    return add_representation(
        ShaderProgram::laplacian, representation_config(config_, d),
        {{ShaderBinding::laplacian_eigen,
          f4,
          d.light_count,
          d.view_count,
          (d.max_level + 1) * d.components,
          1,
          1,
          true,
          {d.eigen.data()},
          16,
          false},
         {ShaderBinding::laplacian_weights, f4, d.width, d.height, groups, d.max_level + 1, 1, true, weight_mips, 16,
          false},
         {ShaderBinding::laplacian_mean, f4, d.light_count, d.view_count, 1, 1, 1, false, {d.mean.data()}, 16, false},
         {ShaderBinding::angular_index,
          VK_FORMAT_R32G32B32A32_UINT,
          res,
          res,
          2,
          1,
          1,
          true,
          {index.data()},
          16,
          false},
         {ShaderBinding::angular_weight, f4, res, res, 2, 1, 1, true, {weight.data()}, 16, false}});
  }

  Result<MaterialHandle> create_lpca_material(const LpcaMaterialData& d) override {
    if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: create_lpca_material before init");
    if (VoidResult v = validate_material(d, config_); !v) return v.error();
    const uint32_t R = d.grid_resolution;
    const VkFormat f4 = VK_FORMAT_R32G32B32A32_SFLOAT;
    return add_representation(ShaderProgram::lpca, representation_config(config_, d),
                              {{ShaderBinding::lpca_cluster,
                                VK_FORMAT_R32_UINT,
                                d.width,
                                d.height,
                                1,
                                1,
                                1,
                                false,
                                {d.cluster.data()},
                                4,
                                false},
                               {ShaderBinding::lpca_weights,
                                f4,
                                d.width,
                                d.height,
                                (d.components + 3) / 4,
                                1,
                                1,
                                true,
                                {d.weights.data()},
                                16,
                                false},
                               // paper 002 §6.2: the eigen-BRDF volume, linear filtering in s_v, t_v, s_l
                               {ShaderBinding::lpca_volume,
                                f4,
                                (d.components + 1) * R,
                                d.clusters * R,
                                1,
                                1,
                                R * R,
                                false,
                                {d.volume.data()},
                                16,
                                true}});
  }

  Result<MaterialHandle> create_pca_views_material(const PcaViewsMaterialData& d) override {
    if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: create_pca_views_material before init");
    if (VoidResult v = validate_material(d, config_); !v) return v.error();
    std::vector<uint32_t> index;
    std::vector<float> weight;
    pack_angular_tables_rgba(d.angular, index, weight);
    const uint32_t res = d.angular.resolution, groups = (d.view_count + d.views_per_group - 1) / d.views_per_group;
    const VkFormat f4 = VK_FORMAT_R32G32B32A32_SFLOAT;
    return add_representation(
        ShaderProgram::pca_views, representation_config(config_, d),
        {{ShaderBinding::pca_l,
          f4,
          d.width,
          d.height,
          groups * ((d.components + 4) / 4),
          1,
          1,
          true,
          {d.l.data()},
          16,
          false},
         {ShaderBinding::pca_r,
          f4,
          d.components,
          d.light_count * d.view_count,
          1,
          1,
          1,
          false,
          {d.r.data()},
          16,
          false},
         {ShaderBinding::angular_index,
          VK_FORMAT_R32G32B32A32_UINT,
          res,
          res,
          2,
          1,
          1,
          true,
          {index.data()},
          16,
          false},
         {ShaderBinding::angular_weight, f4, res, res, 2, 1, 1, true, {weight.data()}, 16, false}});
  }

  Status upload_tiles(std::span<const TileUpload> tiles) noexcept override {
    if (!initialised_) return Status::invalid_argument;
    const VirtualTextureConfig& vt = config_.vt;
    const size_t padded = vt.padded_tile_size();
    const size_t bytes = padded * padded * 8;
    for (const TileUpload& t : tiles)
      if (t.slot >= vt.slot_count() || t.texels.size() != padded * padded * 4) return Status::invalid_argument;
    FrameContext& c = open_context();
    if (c.staging_offset + bytes * tiles.size() > c.staging.size) return Status::insufficient_space;
    for (const TileUpload& t : tiles) {
      std::memcpy(static_cast<char*>(c.staging.mapped) + c.staging_offset, t.texels.data(), bytes);
      const SlotPlacement p = slot_placement(vt, t.slot);
      VkBufferImageCopy region{};
      region.bufferOffset = c.staging_offset;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, p.layer, 1};
      region.imageOffset = {static_cast<int32_t>(p.x), static_cast<int32_t>(p.y), 0};
      region.imageExtent = {static_cast<uint32_t>(padded), static_cast<uint32_t>(padded), 1};
      vkCmdCopyBufferToImage(c.cmd, c.staging.buffer, cache_.image, VK_IMAGE_LAYOUT_GENERAL, 1, &region);
      c.staging_offset += bytes;
    }
    full_barrier(c.cmd);
    return Status::success;
  }

  Status apply_page_table_writes(std::span<const PageTableWrite> writes) noexcept override {
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

  Status begin_frame(const FrameDesc& frame) noexcept override {
    if (!initialised_ || frame.width == 0 || frame.height == 0 || frame.feedback_width == 0 ||
        frame.feedback_height == 0 || frame.width > limits_.maxImageDimension2D ||
        frame.height > limits_.maxImageDimension2D)
      return Status::invalid_argument;
    if (frame.width != frame_.width || frame.height != frame_.height || frame.feedback_width != frame_.feedback_width ||
        frame.feedback_height != frame_.feedback_height || !color_.image) {
      vkDeviceWaitIdle(device_);  // size change: set-up work
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
    feedback_drawn_ = false;
    in_frame_ = true;
    return Status::success;
  }

  Status draw(ShaderProgram program, MeshHandle mesh, MaterialHandle material,
              const ShaderParams& params) noexcept override {
    if (!in_frame_ || mesh.id == 0 || mesh.id > meshes_.size() || material.id == 0 || material.id > materials_.size())
      return Status::invalid_argument;
    const VkMaterial& m = materials_[material.id - 1];
    if (m.program != ShaderProgram::fmf) {  // laplacian / lpca / pca_views: the material's own pipeline
      if (m.program != program) return Status::invalid_argument;
      return record_draw(m.pipeline, m.set, meshes_[mesh.id - 1], params, color_, color_depth_, frame_.width,
                         frame_.height, rep_pipeline_layout_[rep_kind(program)]);
    }
    VkPipeline pipeline = VK_NULL_HANDLE;
    if (program == ShaderProgram::fmf && m.eigen_textures.image)
      pipeline = fmf_;
    else if (program == ShaderProgram::bsvtf)
      pipeline = bsvtf_;
    else
      return Status::invalid_argument;
    return record_draw(pipeline, m.set, meshes_[mesh.id - 1], params, color_, color_depth_, frame_.width,
                       frame_.height);
  }

  Status draw_feedback(MeshHandle mesh, const ShaderParams& params) noexcept override {
    if (!in_frame_ || mesh.id == 0 || mesh.id > meshes_.size()) return Status::invalid_argument;
    const Status s = record_draw(feedback_, feedback_set_, meshes_[mesh.id - 1], params, feedback_color_,
                                 feedback_depth_, frame_.feedback_width, frame_.feedback_height);
    if (s == Status::success) feedback_drawn_ = true;
    return s;
  }

  Status end_frame() noexcept override {
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
      const VkDeviceSize bytes = VkDeviceSize{frame_.feedback_width} * frame_.feedback_height * 4;
      if (slot->buffer.size < bytes) {
        // Grows only when the feedback size grows; a dropped slot may still be read by the GPU.
        vkDeviceWaitIdle(device_);
        destroy(slot->buffer);
        if (!create_buffer(slot->buffer, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT)) return Status::unsupported;
      }
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {frame_.feedback_width, frame_.feedback_height, 1};
      vkCmdCopyImageToBuffer(c.cmd, feedback_color_.image, VK_IMAGE_LAYOUT_GENERAL, slot->buffer.buffer, 1, &region);
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

  bool poll_feedback(FeedbackFrame& out) noexcept override {
    update_completed();
    FeedbackSlot* oldest = nullptr;
    for (FeedbackSlot& s : ring_)
      if (s.pending && (!oldest || s.frame < oldest->frame)) oldest = &s;
    if (!oldest || oldest->serial > completed_serial_) return false;
    const size_t n = static_cast<size_t>(oldest->width) * oldest->height;
    if (readback_.size() < n) readback_.resize(n);                // grows to the largest feedback size once
    std::memcpy(readback_.data(), oldest->buffer.mapped, n * 4);  // row 0 = top (flipped viewport)
    out.frame = oldest->frame;
    out.width = oldest->width;
    out.height = oldest->height;
    out.words = std::span<const uint32_t>(readback_.data(), n);
    oldest->pending = false;
    return true;
  }

  uint32_t feedback_ring_size() const noexcept override { return static_cast<uint32_t>(ring_.size()); }
  uint64_t dropped_feedback() const noexcept override { return dropped_; }

  Status read_color(ImageView<float> out) noexcept override {
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

  Status wait_idle() noexcept override {
    if (vkQueueWaitIdle(queue_) != VK_SUCCESS) return Status::io_error;
    completed_serial_ = next_serial_ - 1;
    return Status::success;
  }

 private:
  // --- laplacian / lpca / pca_views materials -----------------------------------------------
  static int rep_kind(ShaderProgram p) noexcept {
    return p == ShaderProgram::laplacian ? 0 : p == ShaderProgram::lpca ? 1 : 2;
  }

  /// Creates and uploads `textures`, the program's set layout (first use), its pipeline and
  /// descriptor set. Set-up only; nothing leaks on failure.
  Result<MaterialHandle> add_representation(ShaderProgram program, const ShaderConfig& config,
                                            const std::vector<RepTexture>& textures) {
    const int kind = rep_kind(program);
    if (!rep_set_layout_[kind]) {
      VkDescriptorSetLayoutBinding b[7];
      b[0] = VkDescriptorSetLayoutBinding{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC, 1,
                                          VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
      for (size_t i = 0; i < textures.size(); ++i)
        b[i + 1] = VkDescriptorSetLayoutBinding{static_cast<uint32_t>(textures[i].binding),
                                                VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                                VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
      VkDescriptorSetLayoutCreateInfo lci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
      lci.bindingCount = static_cast<uint32_t>(textures.size() + 1);
      lci.pBindings = b;
      BTFLOD_VK_CHECK(vkCreateDescriptorSetLayout(device_, &lci, nullptr, &rep_set_layout_[kind]),
                      "vkCreateDescriptorSetLayout");
      VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
      plci.setLayoutCount = 1;
      plci.pSetLayouts = &rep_set_layout_[kind];
      BTFLOD_VK_CHECK(vkCreatePipelineLayout(device_, &plci, nullptr, &rep_pipeline_layout_[kind]),
                      "vkCreatePipelineLayout");
    }
    VkMaterial m;
    m.program = program;
    VoidResult r;
    for (size_t i = 0; i < textures.size() && r; ++i) {
      const RepTexture& t = textures[i];
      r = create_texture(m.rep[i], t.format, t.width, t.height, t.layers, t.mips, 0, t.array_view, t.depth);
      if (r) r = upload_texture(m.rep[i], t.data, t.texel_bytes);
    }
    if (r) {
      Result<GlslProgramSource> src = generate_program(program, GlslTarget::vulkan450, config);
      if (!src) r = src.error();
      Result<VkPipeline> p = r ? create_pipeline(*src, shader_program_name(program), VK_FORMAT_R32G32B32A32_SFLOAT,
                                                 rep_pipeline_layout_[kind])
                               : Result<VkPipeline>(r.error());
      if (p)
        m.pipeline = *p;
      else
        r = p.error();
    }
    if (r) {
      VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
      ai.descriptorPool = descriptor_pool_;
      ai.descriptorSetCount = 1;
      ai.pSetLayouts = &rep_set_layout_[kind];
      if (vkAllocateDescriptorSets(device_, &ai, &m.set) != VK_SUCCESS)
        r = make_error(Status::unsupported, "Vulkan: vkAllocateDescriptorSets (too many materials?)");
    }
    if (!r) {
      destroy_material(m);
      return r.error();
    }
    VkDescriptorBufferInfo ubo{shared_ubo().buffer, 0, sizeof(ShaderParams)};
    VkDescriptorImageInfo images[6];
    VkWriteDescriptorSet w[7];
    for (size_t i = 0; i <= textures.size(); ++i) {
      w[i] = VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      w[i].dstSet = m.set;
      w[i].descriptorCount = 1;
      if (i == 0) {
        w[i].dstBinding = 0;
        w[i].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC;
        w[i].pBufferInfo = &ubo;
      } else {
        const RepTexture& t = textures[i - 1];
        images[i - 1] =
            VkDescriptorImageInfo{t.linear ? linear_clamp_ : nearest_, m.rep[i - 1].view, VK_IMAGE_LAYOUT_GENERAL};
        w[i].dstBinding = static_cast<uint32_t>(t.binding);
        w[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        w[i].pImageInfo = &images[i - 1];
      }
    }
    vkUpdateDescriptorSets(device_, static_cast<uint32_t>(textures.size() + 1), w, 0, nullptr);
    materials_.push_back(m);
    return MaterialHandle{static_cast<uint32_t>(materials_.size())};
  }

  // --- resources ---------------------------------------------------------------------------
  uint32_t memory_type(uint32_t bits, VkMemoryPropertyFlags want) const {
    for (uint32_t i = 0; i < memory_props_.memoryTypeCount; ++i)
      if ((bits & (1u << i)) && (memory_props_.memoryTypes[i].propertyFlags & want) == want) return i;
    return UINT32_MAX;
  }

  VoidResult create_buffer(Buffer& b, VkDeviceSize size, VkBufferUsageFlags usage) {
    b.size = size;
    VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    bci.size = size;
    bci.usage = usage;
    BTFLOD_VK_CHECK(vkCreateBuffer(device_, &bci, nullptr, &b.buffer), "vkCreateBuffer");
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device_, b.buffer, &req);
    VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    mai.allocationSize = req.size;
    mai.memoryTypeIndex =
        memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    if (mai.memoryTypeIndex == UINT32_MAX)
      return make_error(Status::unsupported, "Vulkan: no host-visible coherent memory for a buffer");
    BTFLOD_VK_CHECK(vkAllocateMemory(device_, &mai, nullptr, &b.memory), "vkAllocateMemory (buffer)");
    BTFLOD_VK_CHECK(vkBindBufferMemory(device_, b.buffer, b.memory, 0), "vkBindBufferMemory");
    BTFLOD_VK_CHECK(vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
    return {};
  }

  void destroy(Buffer& b) {
    if (b.buffer) vkDestroyBuffer(device_, b.buffer, nullptr);
    if (b.memory) vkFreeMemory(device_, b.memory, nullptr);
    b = Buffer{};
  }

  VoidResult create_texture(Texture& t, VkFormat format, uint32_t w, uint32_t h, uint32_t layers, uint32_t mips,
                            VkImageUsageFlags extra = 0, bool array_view = true, uint32_t depth3d = 1) {
    const bool depth = format == VK_FORMAT_D32_SFLOAT;
    t.format = format;
    t.width = w;
    t.height = h;
    t.layers = layers;
    t.mips = mips;
    t.depth = depth3d;
    VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ici.imageType = depth3d > 1 ? VK_IMAGE_TYPE_3D : VK_IMAGE_TYPE_2D;
    ici.format = format;
    ici.extent = {w, h, depth3d};
    ici.mipLevels = mips;
    ici.arrayLayers = layers;
    ici.samples = VK_SAMPLE_COUNT_1_BIT;
    ici.tiling = VK_IMAGE_TILING_OPTIMAL;
    ici.usage = extra | VK_IMAGE_USAGE_TRANSFER_DST_BIT | (depth ? 0 : VK_IMAGE_USAGE_SAMPLED_BIT);
    ici.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    BTFLOD_VK_CHECK(vkCreateImage(device_, &ici, nullptr, &t.image), "vkCreateImage");
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(device_, t.image, &req);
    VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    mai.allocationSize = req.size;
    mai.memoryTypeIndex = memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (mai.memoryTypeIndex == UINT32_MAX) mai.memoryTypeIndex = memory_type(req.memoryTypeBits, 0);
    BTFLOD_VK_CHECK(vkAllocateMemory(device_, &mai, nullptr, &t.memory), "vkAllocateMemory (image)");
    BTFLOD_VK_CHECK(vkBindImageMemory(device_, t.image, t.memory, 0), "vkBindImageMemory");
    VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vci.image = t.image;
    vci.viewType = depth3d > 1  ? VK_IMAGE_VIEW_TYPE_3D
                   : array_view ? VK_IMAGE_VIEW_TYPE_2D_ARRAY
                                : VK_IMAGE_VIEW_TYPE_2D;
    vci.format = format;
    vci.subresourceRange = {
        static_cast<VkImageAspectFlags>(depth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT), 0, mips, 0,
        layers};
    BTFLOD_VK_CHECK(vkCreateImageView(device_, &vci, nullptr, &t.view), "vkCreateImageView");
    // Every image lives in GENERAL from here on.
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    if (VoidResult r = begin_one_shot(cmd); !r) return r;
    VkImageMemoryBarrier b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    b.srcAccessMask = 0;
    b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = VK_IMAGE_LAYOUT_GENERAL;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = t.image;
    b.subresourceRange = vci.subresourceRange;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0, nullptr, 0,
                         nullptr, 1, &b);
    return end_one_shot(cmd);
  }

  void destroy(Texture& t) {
    if (t.view) vkDestroyImageView(device_, t.view, nullptr);
    if (t.image) vkDestroyImage(device_, t.image, nullptr);
    if (t.memory) vkFreeMemory(device_, t.memory, nullptr);
    t = Texture{};
  }

  void destroy_material(VkMaterial& m) {
    destroy(m.eigen_abrdfs);
    destroy(m.angular_index);
    destroy(m.angular_weight);
    destroy(m.eigen_textures);
    for (Texture& t : m.rep) destroy(t);
    if (m.pipeline) vkDestroyPipeline(device_, m.pipeline, nullptr);
    m.pipeline = VK_NULL_HANDLE;
  }

  /// Uploads every mip (data[m]: all layers, layer-major, tightly packed) through a staging buffer.
  VoidResult upload_texture(Texture& t, const std::vector<const void*>& data, uint32_t texel_bytes) {
    std::vector<VkBufferImageCopy> regions;
    VkDeviceSize total = 0;
    for (uint32_t m = 0; m < t.mips; ++m) {
      const uint32_t w = std::max(t.width >> m, 1u), h = std::max(t.height >> m, 1u);
      VkBufferImageCopy r{};
      r.bufferOffset = total;
      r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m, 0, t.layers};
      r.imageExtent = {w, h, t.depth};
      regions.push_back(r);
      total += VkDeviceSize{w} * h * t.layers * t.depth * texel_bytes;
    }
    Buffer staging;
    if (VoidResult r = create_buffer(staging, total, VK_BUFFER_USAGE_TRANSFER_SRC_BIT); !r) return r;
    for (uint32_t m = 0; m < t.mips && m < data.size(); ++m) {
      const VkDeviceSize end = m + 1 < t.mips ? regions[m + 1].bufferOffset : total;
      std::memcpy(static_cast<char*>(staging.mapped) + regions[m].bufferOffset, data[m], end - regions[m].bufferOffset);
    }
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VoidResult r = begin_one_shot(cmd);
    if (r) {
      vkCmdCopyBufferToImage(cmd, staging.buffer, t.image, VK_IMAGE_LAYOUT_GENERAL,
                             static_cast<uint32_t>(regions.size()), regions.data());
      full_barrier(cmd);
      r = end_one_shot(cmd);
    }
    destroy(staging);
    return r;
  }

  bool create_targets() {
    const VkImageUsageFlags color = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    const VkImageUsageFlags depth = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
    return create_texture(color_, VK_FORMAT_R32G32B32A32_SFLOAT, frame_.width, frame_.height, 1, 1, color, false) &&
           create_texture(color_depth_, VK_FORMAT_D32_SFLOAT, frame_.width, frame_.height, 1, 1, depth, false) &&
           create_texture(feedback_color_, VK_FORMAT_R32_UINT, frame_.feedback_width, frame_.feedback_height, 1, 1,
                          color, false) &&
           create_texture(feedback_depth_, VK_FORMAT_D32_SFLOAT, frame_.feedback_width, frame_.feedback_height, 1, 1,
                          depth, false);
  }

  void destroy_targets() {
    for (Texture* t : {&color_, &color_depth_, &feedback_color_, &feedback_depth_}) destroy(*t);
  }

  // --- pipelines and descriptors ----------------------------------------------------------
  VoidResult create_layout() {
    VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    sci.magFilter = sci.minFilter = VK_FILTER_NEAREST;
    sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sci.maxLod = VK_LOD_CLAMP_NONE;
    BTFLOD_VK_CHECK(vkCreateSampler(device_, &sci, nullptr, &nearest_), "vkCreateSampler");
    sci.magFilter = sci.minFilter = VK_FILTER_LINEAR;
    sci.maxLod = 0.0f;
    BTFLOD_VK_CHECK(vkCreateSampler(device_, &sci, nullptr, &linear_clamp_), "vkCreateSampler");
    sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
    sci.addressModeU = sci.addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    sci.maxLod = VK_LOD_CLAMP_NONE;
    BTFLOD_VK_CHECK(vkCreateSampler(device_, &sci, nullptr, &linear_repeat_), "vkCreateSampler");
    VkDescriptorSetLayoutBinding b[kBindingCount];
    for (uint32_t i = 0; i < kBindingCount; ++i) {
      b[i] = VkDescriptorSetLayoutBinding{};
      b[i].binding = i;
      b[i].descriptorCount = 1;
      b[i].stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
      b[i].descriptorType =
          i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    }
    VkDescriptorSetLayoutCreateInfo lci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    lci.bindingCount = kBindingCount;
    lci.pBindings = b;
    BTFLOD_VK_CHECK(vkCreateDescriptorSetLayout(device_, &lci, nullptr, &set_layout_), "vkCreateDescriptorSetLayout");
    VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    plci.setLayoutCount = 1;
    plci.pSetLayouts = &set_layout_;
    BTFLOD_VK_CHECK(vkCreatePipelineLayout(device_, &plci, nullptr, &pipeline_layout_), "vkCreatePipelineLayout");
    constexpr uint32_t kMaxSets = 256;
    VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC, kMaxSets},
                                     {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, kMaxSets * (kBindingCount - 1)}};
    VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    dpci.maxSets = kMaxSets;
    dpci.poolSizeCount = 2;
    dpci.pPoolSizes = sizes;
    BTFLOD_VK_CHECK(vkCreateDescriptorPool(device_, &dpci, nullptr, &descriptor_pool_), "vkCreateDescriptorPool");
    return {};
  }

  /// A descriptor set with the per-frame UBO (dynamic offset), the cache and page table, and the
  /// material's textures (dummies when m is null or has no V').
  Result<VkDescriptorSet> allocate_set(const VkMaterial* m) {
    VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = descriptor_pool_;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &set_layout_;
    VkDescriptorSet set = VK_NULL_HANDLE;
    BTFLOD_VK_CHECK(vkAllocateDescriptorSets(device_, &ai, &set), "vkAllocateDescriptorSets (too many materials?)");
    // All frame contexts share one uniform buffer, sliced by dynamic offsets (context, draw).
    VkDescriptorBufferInfo ubo{shared_ubo().buffer, 0, sizeof(ShaderParams)};
    auto image = [&](const Texture& t, VkSampler s) {
      return VkDescriptorImageInfo{s, t.view, VK_IMAGE_LAYOUT_GENERAL};
    };
    const VkDescriptorImageInfo images[kBindingCount - 1] = {
        image(m ? m->eigen_abrdfs : dummy_float_, nearest_),
        image(m ? m->angular_index : dummy_uint_, nearest_),
        image(m ? m->angular_weight : dummy_float_, nearest_),
        image(m && m->eigen_textures.image ? m->eigen_textures : dummy_float_, linear_repeat_),
        image(cache_, linear_clamp_),
        image(page_table_, nearest_),
    };
    VkWriteDescriptorSet w[kBindingCount];
    for (uint32_t i = 0; i < kBindingCount; ++i) {
      w[i] = VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      w[i].dstSet = set;
      w[i].dstBinding = i;
      w[i].descriptorCount = 1;
      w[i].descriptorType =
          i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      if (i == 0)
        w[i].pBufferInfo = &ubo;
      else
        w[i].pImageInfo = &images[i - 1];
    }
    vkUpdateDescriptorSets(device_, kBindingCount, w, 0, nullptr);
    return set;
  }

  Buffer& shared_ubo() { return ubo_all_; }

  Result<VkPipeline> create_pipeline(const GlslProgramSource& src, const char* name, VkFormat color_format,
                                     VkPipelineLayout layout = VK_NULL_HANDLE) {
    Result<std::vector<uint32_t>> vs = compile_spirv(src.vertex, "vert", name);
    if (!vs) return vs.error();
    Result<std::vector<uint32_t>> fs = compile_spirv(src.fragment, "frag", name);
    if (!fs) return fs.error();
    VkShaderModule modules[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
    const std::vector<uint32_t>* code[2] = {&*vs, &*fs};
    for (int i = 0; i < 2; ++i) {
      VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
      smci.codeSize = code[i]->size() * 4;
      smci.pCode = code[i]->data();
      if (vkCreateShaderModule(device_, &smci, nullptr, &modules[i]) != VK_SUCCESS) {
        if (i) vkDestroyShaderModule(device_, modules[0], nullptr);
        return make_error(Status::unsupported, "Vulkan: vkCreateShaderModule failed for %s", name);
      }
    }
    VkPipelineShaderStageCreateInfo stages[2] = {{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
                                                 {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO}};
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = modules[0];
    stages[0].pName = "main";
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = modules[1];
    stages[1].pName = "main";
    VkVertexInputBindingDescription binding{0, sizeof(MeshVertex), VK_VERTEX_INPUT_RATE_VERTEX};
    const VkVertexInputAttributeDescription attrs[4] = {
        {static_cast<uint32_t>(VertexAttribute::position), 0, VK_FORMAT_R32G32B32_SFLOAT,
         offsetof(MeshVertex, position)},
        {static_cast<uint32_t>(VertexAttribute::normal), 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, normal)},
        {static_cast<uint32_t>(VertexAttribute::tangent), 0, VK_FORMAT_R32G32B32A32_SFLOAT,
         offsetof(MeshVertex, tangent)},
        {static_cast<uint32_t>(VertexAttribute::uv), 0, VK_FORMAT_R32G32_SFLOAT, offsetof(MeshVertex, uv)}};
    VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    vi.vertexBindingDescriptionCount = 1;
    vi.pVertexBindingDescriptions = &binding;
    vi.vertexAttributeDescriptionCount = 4;
    vi.pVertexAttributeDescriptions = attrs;
    VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    vp.viewportCount = 1;
    vp.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    rs.polygonMode = VK_POLYGON_MODE_FILL;
    rs.cullMode = VK_CULL_MODE_NONE;
    rs.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    rs.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
    ds.depthTestEnable = VK_TRUE;
    ds.depthWriteEnable = VK_TRUE;
    ds.depthCompareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
    VkPipelineColorBlendAttachmentState blend{};
    blend.colorWriteMask =
        VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    cb.attachmentCount = 1;
    cb.pAttachments = &blend;
    const VkDynamicState dyn[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
    dy.dynamicStateCount = 2;
    dy.pDynamicStates = dyn;
    VkPipelineRenderingCreateInfo rci{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
    rci.colorAttachmentCount = 1;
    rci.pColorAttachmentFormats = &color_format;
    rci.depthAttachmentFormat = VK_FORMAT_D32_SFLOAT;
    VkGraphicsPipelineCreateInfo gci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    gci.pNext = &rci;
    gci.stageCount = 2;
    gci.pStages = stages;
    gci.pVertexInputState = &vi;
    gci.pInputAssemblyState = &ia;
    gci.pViewportState = &vp;
    gci.pRasterizationState = &rs;
    gci.pMultisampleState = &ms;
    gci.pDepthStencilState = &ds;
    gci.pColorBlendState = &cb;
    gci.pDynamicState = &dy;
    gci.layout = layout ? layout : pipeline_layout_;
    VkPipeline pipeline = VK_NULL_HANDLE;
    const VkResult r = vkCreateGraphicsPipelines(device_, VK_NULL_HANDLE, 1, &gci, nullptr, &pipeline);
    vkDestroyShaderModule(device_, modules[0], nullptr);
    vkDestroyShaderModule(device_, modules[1], nullptr);
    if (r != VK_SUCCESS)
      return make_error(Status::unsupported, "Vulkan: vkCreateGraphicsPipelines failed for %s (%d)", name,
                        static_cast<int>(r));
    return pipeline;
  }

  // --- recording ---------------------------------------------------------------------------
  static void full_barrier(VkCommandBuffer cmd) {
    VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    b.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &b, 0,
                         nullptr, 0, nullptr);
  }

  Status record_draw(VkPipeline pipeline, VkDescriptorSet set, const VkMesh& mesh, const ShaderParams& params,
                     const Texture& color, const Texture& depth, uint32_t w, uint32_t h,
                     VkPipelineLayout layout = VK_NULL_HANDLE) {
    FrameContext& c = open_context();
    if (c.ubo_offset + ubo_stride_ > ubo_stride_ * options_.max_draws_per_frame) return Status::insufficient_space;
    const VkDeviceSize offset = context_ubo_base() + c.ubo_offset;
    std::memcpy(static_cast<char*>(ubo_all_.mapped) + offset, &params, sizeof(ShaderParams));
    c.ubo_offset += ubo_stride_;
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = color.view;
    ca.imageLayout = VK_IMAGE_LAYOUT_GENERAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    VkRenderingAttachmentInfo da = ca;
    da.imageView = depth.view;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {w, h}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(c.cmd, &ri);
    // Negative height: NDC y = +1 lands on row 0, as in OpenGL after its bottom-up readback.
    const VkViewport viewport{0.0f, static_cast<float>(h), static_cast<float>(w), -static_cast<float>(h), 0.0f, 1.0f};
    const VkRect2D scissor{{0, 0}, {w, h}};
    vkCmdSetViewport(c.cmd, 0, 1, &viewport);
    vkCmdSetScissor(c.cmd, 0, 1, &scissor);
    vkCmdBindPipeline(c.cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    const uint32_t dynamic_offset = static_cast<uint32_t>(offset);
    vkCmdBindDescriptorSets(c.cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout ? layout : pipeline_layout_, 0, 1, &set, 1,
                            &dynamic_offset);
    const VkDeviceSize zero = 0;
    vkCmdBindVertexBuffers(c.cmd, 0, 1, &mesh.vertices.buffer, &zero);
    vkCmdBindIndexBuffer(c.cmd, mesh.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
    vkCmdDrawIndexed(c.cmd, mesh.index_count, 1, 0, 0, 0);
    vkCmdEndRendering(c.cmd);
    full_barrier(c.cmd);
    return Status::success;
  }

  static void clear_pass(VkCommandBuffer cmd, const Texture& color, const Texture& depth, VkClearValue value,
                         uint32_t w, uint32_t h) {
    VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    ca.imageView = color.view;
    ca.imageLayout = VK_IMAGE_LAYOUT_GENERAL;
    ca.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ca.clearValue = value;
    VkRenderingAttachmentInfo da = ca;
    da.imageView = depth.view;
    da.clearValue.depthStencil = {1.0f, 0};
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {w, h}};
    ri.layerCount = 1;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &ca;
    ri.pDepthAttachment = &da;
    vkCmdBeginRendering(cmd, &ri);
    vkCmdEndRendering(cmd);
  }

  VkDeviceSize context_ubo_base() const { return VkDeviceSize{current_} * ubo_stride_ * options_.max_draws_per_frame; }

  /// The context being recorded; opens the next one (waiting only if the GPU is
  /// frames_in_flight submissions behind) when none is open.
  FrameContext& open_context() {
    FrameContext& c = contexts_[current_];
    if (!recording_) {
      if (c.serial) {
        vkWaitForFences(device_, 1, &c.fence, VK_TRUE, UINT64_MAX);
        completed_serial_ = std::max(completed_serial_, c.serial);
        vkResetFences(device_, 1, &c.fence);
      }
      vkResetCommandBuffer(c.cmd, 0);
      VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
      bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
      vkBeginCommandBuffer(c.cmd, &bi);
      c.ubo_offset = 0;
      c.staging_offset = 0;
      recording_ = true;
    }
    return c;
  }

  bool submit_context() {
    FrameContext& c = contexts_[current_];
    if (vkEndCommandBuffer(c.cmd) != VK_SUCCESS) return false;
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &c.cmd;
    const bool ok = vkQueueSubmit(queue_, 1, &si, c.fence) == VK_SUCCESS;
    c.serial = next_serial_++;
    recording_ = false;
    current_ = (current_ + 1) % static_cast<uint32_t>(contexts_.size());
    return ok;
  }

  void update_completed() {
    for (FrameContext& c : contexts_)
      if (c.serial > completed_serial_ && vkGetFenceStatus(device_, c.fence) == VK_SUCCESS)
        completed_serial_ = c.serial;
  }

  VoidResult begin_one_shot(VkCommandBuffer& cmd) {
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = one_shot_pool_;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    BTFLOD_VK_CHECK(vkAllocateCommandBuffers(device_, &ai, &cmd), "vkAllocateCommandBuffers");
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    BTFLOD_VK_CHECK(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
    return {};
  }

  /// Submits and waits (set-up and blocking readback only; queue order keeps it after the
  /// frames submitted before).
  VoidResult end_one_shot(VkCommandBuffer cmd) {
    VkResult r = vkEndCommandBuffer(cmd);
    if (r == VK_SUCCESS) {
      VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
      si.commandBufferCount = 1;
      si.pCommandBuffers = &cmd;
      r = vkQueueSubmit(queue_, 1, &si, VK_NULL_HANDLE);
      if (r == VK_SUCCESS) r = vkQueueWaitIdle(queue_);
    }
    vkFreeCommandBuffers(device_, one_shot_pool_, 1, &cmd);
    if (r != VK_SUCCESS)
      return make_error(Status::io_error, "Vulkan: one-shot submit failed (%d)", static_cast<int>(r));
    return {};
  }

 public:
  VoidResult create_shared_ubo() {
    // One host-visible buffer sliced per frame context and per draw (dynamic offsets).
    ubo_stride_ = (sizeof(ShaderParams) + limits_.minUniformBufferOffsetAlignment - 1) /
                  limits_.minUniformBufferOffsetAlignment * limits_.minUniformBufferOffsetAlignment;
    return create_buffer(ubo_all_, ubo_stride_ * options_.max_draws_per_frame * options_.frames_in_flight,
                         VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  }

 private:
  VkBackendOptions options_;
  std::string name_ = "Vulkan";
  VkInstance instance_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkPhysicalDeviceLimits limits_{};
  VkPhysicalDeviceMemoryProperties memory_props_{};
  uint32_t queue_family_ = 0;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool pool_ = VK_NULL_HANDLE, one_shot_pool_ = VK_NULL_HANDLE;
  VkSampler nearest_ = VK_NULL_HANDLE, linear_clamp_ = VK_NULL_HANDLE, linear_repeat_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipeline_layout_ = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
  VkPipeline fmf_ = VK_NULL_HANDLE, bsvtf_ = VK_NULL_HANDLE, feedback_ = VK_NULL_HANDLE;
  VkDescriptorSet feedback_set_ = VK_NULL_HANDLE;
  // Set and pipeline layouts of the laplacian, lpca and pca_views programs (created on first use).
  VkDescriptorSetLayout rep_set_layout_[3] = {VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE};
  VkPipelineLayout rep_pipeline_layout_[3] = {VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE};
  ShaderConfig config_;
  uint32_t vt_layers_ = 0;
  bool initialised_ = false;
  Texture cache_, page_table_, dummy_float_, dummy_uint_;
  Texture color_, color_depth_, feedback_color_, feedback_depth_;
  Buffer ubo_all_, color_readback_;
  VkDeviceSize ubo_stride_ = 256;
  std::vector<FrameContext> contexts_;
  uint32_t current_ = 0;
  bool recording_ = false;
  uint64_t next_serial_ = 1, completed_serial_ = 0;
  std::vector<FeedbackSlot> ring_;
  std::vector<uint32_t> readback_;
  std::vector<VkMesh> meshes_;
  std::vector<VkMaterial> materials_;
  FrameDesc frame_{0, 0, 0, 0, {0, 0, 0, 0}};
  bool in_frame_ = false, feedback_drawn_ = false;
  uint64_t frame_counter_ = 0, dropped_ = 0;
};

}  // namespace

Result<std::unique_ptr<Backend>> create_vk_backend(const VkBackendOptions& options) {
  auto backend = std::make_unique<VkBackend>(options);
  if (VoidResult r = backend->create_device(); !r) return r.error();
  if (VoidResult r = backend->create_shared_ubo(); !r) return r.error();
  return std::unique_ptr<Backend>(std::move(backend));
}

}  // namespace btflod::samples
