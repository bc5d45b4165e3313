// btflod sample — headless Vulkan 1.3 backend: buffers, images, staging uploads, render targets,
// and GLSL → SPIR-V through glslc. See vk_internal.hpp.
#include "vk_internal.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace btflod::samples::vk_detail {

namespace {

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

}  // namespace

/// GLSL → SPIR-V with glslc, or HLSL with glslangValidator -D (subprocess). Results are cached in
/// the temp directory under a hash of (compiler path, stage, language, source): the generated
/// source is deterministic, so every later run (and every test process) skips the ~0.4 s compile.
/// Files are published with rename().
Result<std::vector<uint32_t>> compile_spirv(const std::string& source, const char* stage, const std::string& tag,
                                            bool hlsl) {
  const std::string glslc = hlsl ? BTFLOD_GLSLANG_VALIDATOR : BTFLOD_GLSLC;
  if (glslc.empty())
    return make_error(Status::unsupported, "Vulkan: %s was not found at configure time",
                      hlsl ? "glslangValidator" : "glslc");
  static std::atomic<unsigned> counter{0};
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  char hash[32];
  const std::string key = glslc + "|" + stage + (hlsl ? "|hlsl" : "") + "|vulkan1.1";
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(fnv1a(source, fnv1a(key))));
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
  const std::string flags =
      hlsl ? std::string(" -D -V --target-env vulkan1.1 -e main -S ") + stage : std::string(" --target-env=vulkan1.1");
  const std::string cmd = "\"" + glslc + "\"" + flags + " -o \"" + spv + "\" \"" + src + "\" > \"" + log + "\" 2>&1";
  const int rc = std::system(cmd.c_str());
  std::vector<uint32_t> words = read_words(spv);
  std::ifstream lg(log);
  const std::string log_text((std::istreambuf_iterator<char>(lg)), std::istreambuf_iterator<char>());
  std::error_code ec;
  std::filesystem::remove(src, ec);
  std::filesystem::remove(log, ec);
  if (rc != 0 || words.empty()) {
    std::filesystem::remove(spv, ec);
    return make_error(Status::unsupported, "Vulkan: %s failed on %s shader %s (exit %d): %s", glslc.c_str(), stage,
                      tag.c_str(), rc, log_text.c_str());
  }
  std::filesystem::rename(spv, cached, ec);  // atomic publish; on failure just drop the file
  if (ec) std::filesystem::remove(spv, ec);
  return words;
}

uint32_t find_memory_type(const VkPhysicalDeviceMemoryProperties& memory, uint32_t bits, VkMemoryPropertyFlags want) {
  for (uint32_t i = 0; i < memory.memoryTypeCount; ++i)
    if ((bits & (1u << i)) && (memory.memoryTypes[i].propertyFlags & want) == want) return i;
  return UINT32_MAX;
}

namespace {

// Allocates `req.size` bytes of memory type `type` in `out` and binds them with `bind(out)`;
// `what` names the resource in errors.
template <class Bind>
VoidResult allocate_and_bind(VkDevice device, const VkMemoryRequirements& req, uint32_t type, const char* what,
                             VkDeviceMemory& out, Bind&& bind) {
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = type;
  const VkResult allocated = vkAllocateMemory(device, &mai, nullptr, &out);
  if (allocated != VK_SUCCESS)
    return make_error(Status::unsupported, "Vulkan: vkAllocateMemory (%s) failed (VkResult %d)", what,
                      static_cast<int>(allocated));
  return bind(out);
}

}  // namespace

VoidResult create_host_buffer(VkDevice device, const VkPhysicalDeviceMemoryProperties& memory, Buffer& b,
                              VkDeviceSize size, VkBufferUsageFlags usage) {
  b.size = size;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = usage;
  BTFLOD_VK_CHECK(vkCreateBuffer(device, &bci, nullptr, &b.buffer), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device, b.buffer, &req);
  const uint32_t type = find_memory_type(memory, req.memoryTypeBits,
                                         VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  if (type == UINT32_MAX)
    return make_error(Status::unsupported, "Vulkan: no host-visible coherent memory for a buffer");
  return allocate_and_bind(device, req, type, "buffer", b.memory, [&](VkDeviceMemory m) -> VoidResult {
    BTFLOD_VK_CHECK(vkBindBufferMemory(device, b.buffer, m, 0), "vkBindBufferMemory");
    BTFLOD_VK_CHECK(vkMapMemory(device, m, 0, VK_WHOLE_SIZE, 0, &b.mapped), "vkMapMemory");
    return {};
  });
}

void destroy_buffer(VkDevice device, Buffer& b) {
  if (b.buffer) vkDestroyBuffer(device, b.buffer, nullptr);
  if (b.memory) vkFreeMemory(device, b.memory, nullptr);
  b = Buffer{};
}

VoidResult create_image(VkDevice device, const VkPhysicalDeviceMemoryProperties& memory, Texture& t, VkFormat format,
                        uint32_t w, uint32_t h, uint32_t layers, uint32_t mips, VkImageUsageFlags usage,
                        bool array_view, uint32_t depth3d) {
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
  ici.usage = usage;
  ici.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  BTFLOD_VK_CHECK(vkCreateImage(device, &ici, nullptr, &t.image), "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(device, t.image, &req);
  uint32_t type = find_memory_type(memory, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (type == UINT32_MAX) type = find_memory_type(memory, req.memoryTypeBits, 0);
  return allocate_and_bind(device, req, type, "image", t.memory, [&](VkDeviceMemory m) -> VoidResult {
    BTFLOD_VK_CHECK(vkBindImageMemory(device, t.image, m, 0), "vkBindImageMemory");
    VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vci.image = t.image;
    vci.viewType = depth3d > 1  ? VK_IMAGE_VIEW_TYPE_3D
                   : array_view ? VK_IMAGE_VIEW_TYPE_2D_ARRAY
                                : VK_IMAGE_VIEW_TYPE_2D;
    vci.format = format;
    vci.subresourceRange = texture_range(t);
    BTFLOD_VK_CHECK(vkCreateImageView(device, &vci, nullptr, &t.view), "vkCreateImageView");
    return {};
  });
}

void destroy_texture(VkDevice device, Texture& t) {
  if (t.view) vkDestroyImageView(device, t.view, nullptr);
  if (t.image) vkDestroyImage(device, t.image, nullptr);
  if (t.memory) vkFreeMemory(device, t.memory, nullptr);
  t = Texture{};
}

VoidResult VkBackend::create_texture(Texture& t, VkFormat format, uint32_t w, uint32_t h, uint32_t layers,
                                     uint32_t mips, VkImageUsageFlags extra, bool array_view, uint32_t depth3d) {
  const bool depth = format == VK_FORMAT_D32_SFLOAT;
  const VkImageUsageFlags usage = extra | VK_IMAGE_USAGE_TRANSFER_DST_BIT | (depth ? 0 : VK_IMAGE_USAGE_SAMPLED_BIT);
  if (VoidResult r = create_image(vk_.device, vk_.memory, t, format, w, h, layers, mips, usage, array_view, depth3d);
      !r)
    return r;
  // Every image lives in GENERAL from here on.
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (VoidResult r = begin_one_shot(cmd); !r) return r;
  to_general_layout(cmd, t.image, texture_range(t));
  return end_one_shot(cmd);
}

void VkBackend::destroy_material(VkMaterial& m) {
  destroy(m.eigen_abrdfs);
  destroy(m.angular_index);
  destroy(m.angular_weight);
  destroy(m.eigen_textures);
  for (Texture& t : m.rep) destroy(t);
  if (m.pipeline) vkDestroyPipeline(vk_.device, m.pipeline, nullptr);
  m.pipeline = VK_NULL_HANDLE;
}

VoidResult VkBackend::upload_texture(Texture& t, const std::vector<const void*>& data, uint32_t texel_bytes) {
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
    vkCmdCopyBufferToImage(cmd, staging.buffer, t.image, VK_IMAGE_LAYOUT_GENERAL, static_cast<uint32_t>(regions.size()),
                           regions.data());
    full_barrier(cmd);
    r = end_one_shot(cmd);
  }
  destroy(staging);
  return r;
}

bool VkBackend::create_targets() {
  const VkImageUsageFlags color = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  const VkImageUsageFlags depth = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  return create_texture(color_, VK_FORMAT_R32G32B32A32_SFLOAT, frame_.width, frame_.height, 1, 1, color, false) &&
         create_texture(color_depth_, VK_FORMAT_D32_SFLOAT, frame_.width, frame_.height, 1, 1, depth, false) &&
         create_texture(feedback_color_, VK_FORMAT_R32_UINT, frame_.feedback_width, frame_.feedback_height, 1, 1, color,
                        false) &&
         create_texture(feedback_depth_, VK_FORMAT_D32_SFLOAT, frame_.feedback_width, frame_.feedback_height, 1, 1,
                        depth, false) &&
         create_texture(feedback_full_, VK_FORMAT_R32_UINT, frame_.width, frame_.height, 1, 1,
                        color | VK_IMAGE_USAGE_TRANSFER_DST_BIT, false);
}

void VkBackend::destroy_targets() {
  for (Texture* t : {&color_, &color_depth_, &feedback_color_, &feedback_depth_, &feedback_full_}) destroy(*t);
}

}  // namespace btflod::samples::vk_detail
