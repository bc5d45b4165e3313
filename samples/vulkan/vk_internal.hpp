// btflod sample — internals of the headless Vulkan 1.3 backend (see vk_backend.hpp), shared by
// its translation units; included by nothing outside samples/vulkan.
//
//   vk_backend.cpp          device, init, FMF/BSVTF materials, uploads, frames, feedback, readback
//   vk_representations.cpp  laplacian / lpca / pca_views materials (their textures and pipelines)
//   vk_resources.cpp        buffers, images, staging uploads, render targets, glslc → SPIR-V
//   vk_pipelines.cpp        samplers, descriptor layouts and sets, pipelines, command recording
//
// Kept deliberately plain: one VkDeviceMemory per resource, every image in GENERAL layout,
// full memory barriers between phases, dynamic rendering (one begin/end per draw, load op
// LOAD; targets are cleared with vkCmdClear*Image in begin_frame). Per-frame data (uniform
// slices, upload staging) lives in a ring of frame contexts; feedback is copied into a ring of
// host-visible buffers whose completion is tracked by submission serials, polled via fences.
#pragma once

#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "btflod/runtime/shader/hlsl_generator.hpp"
#include "vk_backend.hpp"

namespace btflod::samples::vk_detail {

constexpr uint32_t kBindingCount = 7;  // ShaderBinding::params … page_table
// The main descriptor set: bindings 0 … kBindingCount − 1, then ShaderBinding::slot_map.
constexpr uint32_t kSetBindingCount = kBindingCount + 1;
constexpr uint32_t set_binding(uint32_t i) {
  return i < kBindingCount ? i : static_cast<uint32_t>(ShaderBinding::slot_map);
}

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

/// One cache pool: its cache texture, its slot map (a 1 × 1 stand-in for rgba16f) and the bsvtf
/// pipelines generated for its tile size and format (compile-time constants of the shaders).
struct VkCachePool {
  VirtualTextureConfig vt;
  Texture cache, slot_map;
  VkPipeline bsvtf = VK_NULL_HANDLE, bsvtf_feedback = VK_NULL_HANDLE;
};

struct VkMaterial {
  Texture eigen_abrdfs, angular_index, angular_weight, eigen_textures;
  VkDescriptorSet set = VK_NULL_HANDLE;
  uint32_t pool = 0;  ///< cache pool its set binds (FmfMaterialData::cache_pool)
  /// laplacian / lpca / pca_views materials: their program (fmf = an FMF material), textures
  /// and pipeline (generated with representation_config()).
  ShaderProgram program = ShaderProgram::fmf;
  uint32_t light_count = 0, view_count = 0, components = 0;  ///< FMF materials: U′'s shape
  Texture rep[6];
  VkPipeline pipeline = VK_NULL_HANDLE;
  bool live = true;  ///< false once destroy_material() released it
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
  /// The buffer holds the full-resolution words of a bsvtf_feedback frame (this frame's desc):
  /// poll_feedback() subsamples them.
  bool full = false;
  FrameDesc desc{};
};

#define BTFLOD_VK_CHECK(expr, what)                                                                                  \
  do {                                                                                                               \
    const VkResult vk_result_ = (expr);                                                                              \
    if (vk_result_ != VK_SUCCESS)                                                                                    \
      return make_error(Status::unsupported, "Vulkan: %s failed (VkResult %d)", what, static_cast<int>(vk_result_)); \
  } while (0)
/// The device of a headless Vulkan 1.3 context, as create_vk13_device() makes it.
struct VkDeviceContext {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties{};
  VkPhysicalDeviceMemoryProperties memory{};
  uint32_t queue_family = 0;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  /// textureCompressionBC is supported and enabled (a bc5_affine cache needs it).
  bool texture_compression_bc = false;
};

/// Creates a Vulkan 1.3 instance for application `app_name` and, on the first physical device
/// of API 1.3 with a graphics queue family, a device (dynamic rendering on, textureCompressionBC
/// on where supported: VkDeviceContext::texture_compression_bc) with one queue of
/// that family. Returns `unsupported` with the reason when there is no Vulkan driver, no such
/// device or a create call fails; the handles created so far stay in `out` either way (the
/// caller destroys them).
VoidResult create_vk13_device(const char* app_name, VkDeviceContext& out);

/// The index of a memory type allowed by `bits` with every property of `want`; UINT32_MAX if
/// there is none.
uint32_t find_memory_type(const VkPhysicalDeviceMemoryProperties& memory, uint32_t bits, VkMemoryPropertyFlags want);

/// Creates `b`: a buffer of `size` bytes for `usage` in host-visible coherent memory, mapped at
/// b.mapped. Returns `unsupported` when there is no such memory or a call fails; what was
/// created stays in `b` (destroy_buffer() releases it).
VoidResult create_host_buffer(VkDevice device, const VkPhysicalDeviceMemoryProperties& memory, Buffer& b,
                              VkDeviceSize size, VkBufferUsageFlags usage);

/// Releases what `b` holds (any part may be null) and resets it.
void destroy_buffer(VkDevice device, Buffer& b);

/// Every mip and layer of `t` (the depth aspect for VK_FORMAT_D32_SFLOAT, else colour).
inline VkImageSubresourceRange texture_range(const Texture& t) {
  return {static_cast<VkImageAspectFlags>(t.format == VK_FORMAT_D32_SFLOAT ? VK_IMAGE_ASPECT_DEPTH_BIT
                                                                           : VK_IMAGE_ASPECT_COLOR_BIT),
          0, t.mips, 0, t.layers};
}

/// Creates `t`: an image of `format` and `usage`, w × h with `layers` layers and `mips` mips
/// (3D with depth `depth3d` when it is > 1), in device-local memory (any memory type when there
/// is none), in layout UNDEFINED, and its view over texture_range(t): 3D, 2D array
/// (`array_view`) or 2D. Returns `unsupported` when a call fails; what was created stays in `t`
/// (destroy_texture() releases it).
VoidResult create_image(VkDevice device, const VkPhysicalDeviceMemoryProperties& memory, Texture& t, VkFormat format,
                        uint32_t w, uint32_t h, uint32_t layers, uint32_t mips, VkImageUsageFlags usage,
                        bool array_view, uint32_t depth3d = 1);

/// Releases what `t` holds (any part may be null) and resets it.
void destroy_texture(VkDevice device, Texture& t);

/// Records a barrier after which every earlier memory write is visible to every later command.
void full_barrier(VkCommandBuffer cmd);

/// Records the move of `range` of `image` from UNDEFINED to GENERAL, its layout from then on.
void to_general_layout(VkCommandBuffer cmd, VkImage image, const VkImageSubresourceRange& range);

/// A primary command buffer allocated from `pool` and begun for one submission.
VoidResult begin_one_shot_commands(VkDevice device, VkCommandPool pool, VkCommandBuffer& cmd);

/// Ends `cmd`, submits it to `queue`, waits until the queue is idle and frees `cmd` to `pool`
/// (also on failure). Returns `io_error` when ending, submitting or waiting fails.
VoidResult submit_one_shot_commands(VkDevice device, VkQueue queue, VkCommandPool pool, VkCommandBuffer cmd);

/// What create_graphics_pipeline() builds: vertex and fragment stages (entry point main), one
/// vertex buffer of MeshVertex with `attributes`, triangle lists, no culling, one sample, no
/// blending, dynamic rendering into `color_formats` (one or two) and `depth_format`.
struct GraphicsPipelineDesc {
  VkShaderModule vertex = VK_NULL_HANDLE, fragment = VK_NULL_HANDLE;
  const VkVertexInputAttributeDescription* attributes = nullptr;
  uint32_t attribute_count = 0;
  const VkFormat* color_formats = nullptr;
  uint32_t color_count = 1;
  VkFormat depth_format = VK_FORMAT_UNDEFINED;  ///< UNDEFINED: no depth attachment or test; else LESS_OR_EQUAL
  const VkViewport* viewport = nullptr;         ///< null: viewport and scissor are dynamic state
  const VkRect2D* scissor = nullptr;
  VkPipelineLayout layout = VK_NULL_HANDLE;
};

/// Creates the pipeline of `desc` on `device` in `out`; returns vkCreateGraphicsPipelines' result.
VkResult create_graphics_pipeline(VkDevice device, const GraphicsPipelineDesc& desc, VkPipeline& out);

/// GLSL → SPIR-V with glslc (subprocess), cached in the temp directory under a hash of
/// (compiler path, stage, source); `hlsl`: HLSL source (entry point main) through
/// glslangValidator -D -V instead. Returns `unsupported` with the compiler log when glslc is
/// missing or fails. Thread-safe (unique temporary names, atomic rename on publish).
Result<std::vector<uint32_t>> compile_spirv(const std::string& source, const char* stage, const std::string& tag,
                                            bool hlsl = false);

/// The btflod::Backend implementation. Single-threaded like every Backend: all calls from one
/// thread. Created by create_vk_backend() (create_device, then create_shared_ubo).
class VkBackend final : public Backend {
 public:
  explicit VkBackend(const VkBackendOptions& o) : options_(o) {
    options_.feedback_ring_size = std::max<uint32_t>(o.feedback_ring_size, 1);
    options_.frames_in_flight = std::max<uint32_t>(o.frames_in_flight, 1);
    options_.max_draws_per_frame = std::max<uint32_t>(o.max_draws_per_frame, 1);
  }

  ~VkBackend() override;
  VoidResult create_device();
  const char* name() const noexcept override { return name_.c_str(); }

  VoidResult init(const ShaderConfig& config, uint32_t virtual_texture_count) override;
  Result<MeshHandle> create_mesh(const MeshData& mesh) override;
  Result<MaterialHandle> create_material(const FmfMaterialData& data) override;
  Result<uint32_t> add_cache_pool(const CacheConfig& cache) override;
  uint32_t cache_pool_count() const noexcept override { return static_cast<uint32_t>(pools_.size()); }
  Result<MaterialHandle> create_laplacian_material(const LaplacianMaterialData& d) override;
  Result<MaterialHandle> create_lpca_material(const LpcaMaterialData& d) override;
  Result<MaterialHandle> create_pca_views_material(const PcaViewsMaterialData& d) override;
  Result<MaterialHandle> create_spmm_material(const SpmmMaterialData& d) override;
  Status upload_tiles(std::span<const TileUpload> tiles) noexcept override;
  Status upload_u_packets(MaterialHandle material, std::span<const UPacketUpload> packets) noexcept override;
  Status destroy_material(MaterialHandle material) override;
  Status apply_page_table_writes(std::span<const PageTableWrite> writes) noexcept override;
  Status begin_frame(const FrameDesc& frame) noexcept override;
  Status draw(ShaderProgram program, MeshHandle mesh, MaterialHandle material,
              const ShaderParams& params) noexcept override;
  Status draw_feedback(MeshHandle mesh, const ShaderParams& params) noexcept override;
  Status end_frame() noexcept override;
  bool poll_feedback(FeedbackFrame& out) noexcept override;
  uint32_t feedback_ring_size() const noexcept override { return static_cast<uint32_t>(ring_.size()); }
  uint64_t dropped_feedback() const noexcept override { return dropped_; }

  Status read_color(ImageView<float> out) noexcept override;
  Status wait_idle() noexcept override;

 private:
  // --- laplacian / lpca / pca_views materials -----------------------------------------------
  static int rep_kind(ShaderProgram p) noexcept {
    return p == ShaderProgram::laplacian ? 0 : p == ShaderProgram::lpca ? 1 : p == ShaderProgram::pca_views ? 2 : 3;
  }

  /// The set-up checks of create_*_material(d) (`call` names it in the error): init() ran and
  /// `d` passes validate_material() for the programs' configuration.
  template <class MaterialData>
  VoidResult check_material(const MaterialData& d, const char* call) const {
    if (!initialised_) return make_error(Status::invalid_argument, "Vulkan: %s before init", call);
    return validate_material(d, config_);
  }

  /// Creates and uploads `textures` (followed, when `angular` is not null, by its tables packed
  /// as the angular_index and angular_weight textures), the program's set layout (first use),
  /// its pipeline and descriptor set. Set-up only; nothing leaks on failure.
  Result<MaterialHandle> add_representation(ShaderProgram program, const ShaderConfig& config,
                                            std::vector<RepTexture> textures,
                                            const AngularTablesData* angular = nullptr);

  // --- resources ---------------------------------------------------------------------------
  VoidResult create_buffer(Buffer& b, VkDeviceSize size, VkBufferUsageFlags usage) {
    return create_host_buffer(vk_.device, vk_.memory, b, size, usage);
  }
  void destroy(Buffer& b) { destroy_buffer(vk_.device, b); }
  VoidResult create_texture(Texture& t, VkFormat format, uint32_t w, uint32_t h, uint32_t layers, uint32_t mips,
                            VkImageUsageFlags extra = 0, bool array_view = true, uint32_t depth3d = 1);
  void destroy(Texture& t) { destroy_texture(vk_.device, t); }
  void destroy_material(VkMaterial& m);

  /// Uploads every mip (data[m]: all layers, layer-major, tightly packed) through a staging buffer.
  VoidResult upload_texture(Texture& t, const std::vector<const void*>& data, uint32_t texel_bytes);
  bool create_targets();
  void destroy_targets();

  // --- pipelines and descriptors ----------------------------------------------------------
  VoidResult create_layout();
  /// The pipeline of `program` generated for `config` (GLSL or HLSL as the options say).
  Result<VkPipeline> create_program_pipeline(ShaderProgram program, const ShaderConfig& config);
  /// The bsvtf pipelines and the cleared cache texture and slot map of config.vt's cache shape
  /// in `pool` (what it made is in `pool` on failure too: the caller destroys it).
  VoidResult create_pool(const ShaderConfig& config, VkCachePool& pool);
  void destroy(VkCachePool& pool);

  /// A descriptor set with the per-frame UBO (dynamic offset), the cache of the material's pool
  /// (pool 0 when m is null) and the page table, and the material's textures (dummies when m is
  /// null or has no V').
  Result<VkDescriptorSet> allocate_set(const VkMaterial* m);
  Buffer& shared_ubo() { return ubo_all_; }

  /// `second_format` (when not VK_FORMAT_UNDEFINED): a second colour attachment (bsvtf_feedback's words).
  Result<VkPipeline> create_pipeline(const GlslProgramSource& src, const char* name, VkFormat color_format,
                                     VkPipelineLayout layout = VK_NULL_HANDLE,
                                     VkFormat second_format = VK_FORMAT_UNDEFINED, bool hlsl = false);

  // --- recording ---------------------------------------------------------------------------
  Status record_draw(VkPipeline pipeline, VkDescriptorSet set, const VkMesh& mesh, const ShaderParams& params,
                     const Texture& color, const Texture& depth, uint32_t w, uint32_t h,
                     VkPipelineLayout layout = VK_NULL_HANDLE, const Texture* second = nullptr);
  static void clear_pass(VkCommandBuffer cmd, const Texture& color, const Texture& depth, VkClearValue value,
                         uint32_t w, uint32_t h);
  VkDeviceSize context_ubo_base() const { return VkDeviceSize{current_} * ubo_stride_ * options_.max_draws_per_frame; }

  /// The context being recorded; opens the next one (waiting only if the GPU is
  /// frames_in_flight submissions behind) when none is open.
  FrameContext& open_context();
  bool submit_context();
  void update_completed();
  VoidResult begin_one_shot(VkCommandBuffer& cmd) { return begin_one_shot_commands(vk_.device, one_shot_pool_, cmd); }

  /// Submits and waits (set-up and blocking readback only; queue order keeps it after the
  /// frames submitted before).
  VoidResult end_one_shot(VkCommandBuffer cmd) {
    return submit_one_shot_commands(vk_.device, vk_.queue, one_shot_pool_, cmd);
  }

 public:
  VoidResult create_shared_ubo();

 private:
  VkBackendOptions options_;
  std::string name_ = "Vulkan";
  VkDeviceContext vk_;  ///< instance, device, queue (create_device)
  VkCommandPool pool_ = VK_NULL_HANDLE, one_shot_pool_ = VK_NULL_HANDLE;
  VkSampler nearest_ = VK_NULL_HANDLE, linear_clamp_ = VK_NULL_HANDLE, linear_repeat_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipeline_layout_ = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
  VkPipeline fmf_ = VK_NULL_HANDLE, feedback_ = VK_NULL_HANDLE;
  std::vector<VkCachePool> pools_;  ///< pool 0: init()'s config.vt; then add_cache_pool()'s
  VkDescriptorSet feedback_set_ = VK_NULL_HANDLE;
  // Set and pipeline layouts of the laplacian, lpca, pca_views and spmm programs (created on first use).
  VkDescriptorSetLayout rep_set_layout_[4] = {VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE};
  VkPipelineLayout rep_pipeline_layout_[4] = {VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE};
  ShaderConfig config_;
  uint32_t vt_layers_ = 0;
  bool initialised_ = false;
  Texture page_table_, dummy_float_, dummy_uint_;
  Texture color_, color_depth_, feedback_color_, feedback_depth_;
  Texture feedback_full_;  ///< bsvtf_feedback: every pixel's word (R32_UINT, screen size)
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
  bool feedback_stored_ = false;  ///< bsvtf_feedback drawn this frame: its words replace the feedback pass
  uint64_t frame_counter_ = 0, dropped_ = 0;
};

}  // namespace btflod::samples::vk_detail
