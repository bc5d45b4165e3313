// btflod sample — headless Vulkan 1.3 backend: samplers, descriptor set layouts and sets, graphics
// pipelines, and command recording (draws, clears, frame contexts, one-shot submits). See
// vk_internal.hpp.
#include "vk_internal.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <vector>

namespace btflod::samples::vk_detail {

VoidResult VkBackend::create_layout() {
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sci.magFilter = sci.minFilter = VK_FILTER_NEAREST;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sci.maxLod = VK_LOD_CLAMP_NONE;
  BTFLOD_VK_CHECK(vkCreateSampler(vk_.device, &sci, nullptr, &nearest_), "vkCreateSampler");
  sci.magFilter = sci.minFilter = VK_FILTER_LINEAR;
  sci.maxLod = 0.0f;
  BTFLOD_VK_CHECK(vkCreateSampler(vk_.device, &sci, nullptr, &linear_clamp_), "vkCreateSampler");
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  sci.addressModeU = sci.addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  sci.maxLod = VK_LOD_CLAMP_NONE;
  BTFLOD_VK_CHECK(vkCreateSampler(vk_.device, &sci, nullptr, &linear_repeat_), "vkCreateSampler");
  VkDescriptorSetLayoutBinding b[kSetBindingCount];
  for (uint32_t i = 0; i < kSetBindingCount; ++i) {
    b[i] = VkDescriptorSetLayoutBinding{};
    b[i].binding = set_binding(i);
    b[i].descriptorCount = 1;
    b[i].stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
    b[i].descriptorType =
        i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  }
  VkDescriptorSetLayoutCreateInfo lci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  lci.bindingCount = kSetBindingCount;
  lci.pBindings = b;
  BTFLOD_VK_CHECK(vkCreateDescriptorSetLayout(vk_.device, &lci, nullptr, &set_layout_), "vkCreateDescriptorSetLayout");
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &set_layout_;
  BTFLOD_VK_CHECK(vkCreatePipelineLayout(vk_.device, &plci, nullptr, &pipeline_layout_), "vkCreatePipelineLayout");
  constexpr uint32_t kMaxSets = 256;
  VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC, kMaxSets},
                                   {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, kMaxSets * (kSetBindingCount - 1)}};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = kMaxSets;
  dpci.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;  // destroy_material() returns its set
  dpci.poolSizeCount = 2;
  dpci.pPoolSizes = sizes;
  BTFLOD_VK_CHECK(vkCreateDescriptorPool(vk_.device, &dpci, nullptr, &descriptor_pool_), "vkCreateDescriptorPool");
  return {};
}

Result<VkDescriptorSet> VkBackend::allocate_set(const VkMaterial* m) {
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = descriptor_pool_;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &set_layout_;
  VkDescriptorSet set = VK_NULL_HANDLE;
  BTFLOD_VK_CHECK(vkAllocateDescriptorSets(vk_.device, &ai, &set), "vkAllocateDescriptorSets (too many materials?)");
  // All frame contexts share one uniform buffer, sliced by dynamic offsets (context, draw).
  VkDescriptorBufferInfo ubo{shared_ubo().buffer, 0, sizeof(ShaderParams)};
  auto image = [&](const Texture& t, VkSampler s) { return VkDescriptorImageInfo{s, t.view, VK_IMAGE_LAYOUT_GENERAL}; };
  const VkDescriptorImageInfo images[kSetBindingCount - 1] = {
      image(m ? m->eigen_abrdfs : dummy_float_, nearest_),
      image(m ? m->angular_index : dummy_uint_, nearest_),
      image(m ? m->angular_weight : dummy_float_, nearest_),
      image(m && m->eigen_textures.image ? m->eigen_textures : dummy_float_, linear_repeat_),
      image(pools_[m ? m->pool : 0].cache, linear_clamp_),
      image(page_table_, nearest_),
      image(pools_[m ? m->pool : 0].slot_map, nearest_),
  };
  VkWriteDescriptorSet w[kSetBindingCount];
  for (uint32_t i = 0; i < kSetBindingCount; ++i) {
    w[i] = VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w[i].dstSet = set;
    w[i].dstBinding = set_binding(i);
    w[i].descriptorCount = 1;
    w[i].descriptorType =
        i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER_DYNAMIC : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    if (i == 0)
      w[i].pBufferInfo = &ubo;
    else
      w[i].pImageInfo = &images[i - 1];
  }
  vkUpdateDescriptorSets(vk_.device, kSetBindingCount, w, 0, nullptr);
  return set;
}

VkResult create_graphics_pipeline(VkDevice device, const GraphicsPipelineDesc& desc, VkPipeline& out) {
  VkPipelineShaderStageCreateInfo stages[2] = {{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO},
                                               {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO}};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = desc.vertex;
  stages[0].pName = "main";
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = desc.fragment;
  stages[1].pName = "main";
  const VkVertexInputBindingDescription binding{0, sizeof(MeshVertex), VK_VERTEX_INPUT_RATE_VERTEX};
  VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vi.vertexBindingDescriptionCount = 1;
  vi.pVertexBindingDescriptions = &binding;
  vi.vertexAttributeDescriptionCount = desc.attribute_count;
  vi.pVertexAttributeDescriptions = desc.attributes;
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.pViewports = desc.viewport;
  vp.scissorCount = 1;
  vp.pScissors = desc.scissor;
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
  const VkPipelineColorBlendAttachmentState blends[2] = {blend, blend};
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = desc.color_count;
  cb.pAttachments = blends;
  const VkDynamicState dyn[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dy{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dy.dynamicStateCount = 2;
  dy.pDynamicStates = dyn;
  VkPipelineRenderingCreateInfo rci{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rci.colorAttachmentCount = desc.color_count;
  rci.pColorAttachmentFormats = desc.color_formats;
  rci.depthAttachmentFormat = desc.depth_format;
  VkGraphicsPipelineCreateInfo gci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gci.pNext = &rci;
  gci.stageCount = 2;
  gci.pStages = stages;
  gci.pVertexInputState = &vi;
  gci.pInputAssemblyState = &ia;
  gci.pViewportState = &vp;
  gci.pRasterizationState = &rs;
  gci.pMultisampleState = &ms;
  gci.pDepthStencilState = desc.depth_format == VK_FORMAT_UNDEFINED ? nullptr : &ds;
  gci.pColorBlendState = &cb;
  gci.pDynamicState = desc.viewport ? nullptr : &dy;
  gci.layout = desc.layout;
  return vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &gci, nullptr, &out);
}

Result<VkPipeline> VkBackend::create_pipeline(const GlslProgramSource& src, const char* name, VkFormat color_format,
                                              VkPipelineLayout layout, VkFormat second_format, bool hlsl) {
  Result<std::vector<uint32_t>> vs = compile_spirv(src.vertex, "vert", name, hlsl);
  if (!vs) return vs.error();
  Result<std::vector<uint32_t>> fs = compile_spirv(src.fragment, "frag", name, hlsl);
  if (!fs) return fs.error();
  VkShaderModule modules[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  const std::vector<uint32_t>* code[2] = {&*vs, &*fs};
  for (int i = 0; i < 2; ++i) {
    VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    smci.codeSize = code[i]->size() * 4;
    smci.pCode = code[i]->data();
    if (vkCreateShaderModule(vk_.device, &smci, nullptr, &modules[i]) != VK_SUCCESS) {
      if (i) vkDestroyShaderModule(vk_.device, modules[0], nullptr);
      return make_error(Status::unsupported, "Vulkan: vkCreateShaderModule failed for %s", name);
    }
  }
  const VkVertexInputAttributeDescription attrs[4] = {
      {static_cast<uint32_t>(VertexAttribute::position), 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, position)},
      {static_cast<uint32_t>(VertexAttribute::normal), 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(MeshVertex, normal)},
      {static_cast<uint32_t>(VertexAttribute::tangent), 0, VK_FORMAT_R32G32B32A32_SFLOAT,
       offsetof(MeshVertex, tangent)},
      {static_cast<uint32_t>(VertexAttribute::uv), 0, VK_FORMAT_R32G32_SFLOAT, offsetof(MeshVertex, uv)}};
  const VkFormat formats[2] = {color_format, second_format};
  GraphicsPipelineDesc desc;
  desc.vertex = modules[0];
  desc.fragment = modules[1];
  desc.attributes = attrs;
  desc.attribute_count = 4;
  desc.color_formats = formats;
  desc.color_count = second_format == VK_FORMAT_UNDEFINED ? 1 : 2;
  desc.depth_format = VK_FORMAT_D32_SFLOAT;
  desc.layout = layout ? layout : pipeline_layout_;
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult r = create_graphics_pipeline(vk_.device, desc, pipeline);
  vkDestroyShaderModule(vk_.device, modules[0], nullptr);
  vkDestroyShaderModule(vk_.device, modules[1], nullptr);
  if (r != VK_SUCCESS)
    return make_error(Status::unsupported, "Vulkan: vkCreateGraphicsPipelines failed for %s (%d)", name,
                      static_cast<int>(r));
  return pipeline;
}

// Dynamic rendering into one colour and one depth target of w × h: both loaded, or (`clear`
// not null) the colour cleared to *clear and the depth to 1. `second` (loaded) is a second
// colour target.
static void begin_rendering(VkCommandBuffer cmd, const Texture& color, const Texture& depth, uint32_t w, uint32_t h,
                            const VkClearValue* clear, const Texture* second = nullptr) {
  VkRenderingAttachmentInfo ca{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  ca.imageView = color.view;
  ca.imageLayout = VK_IMAGE_LAYOUT_GENERAL;
  ca.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  ca.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  if (clear) ca.clearValue = *clear;
  VkRenderingAttachmentInfo colors[2] = {ca, ca};
  if (second) colors[1].imageView = second->view;
  VkRenderingAttachmentInfo da = ca;
  da.imageView = depth.view;
  if (clear) da.clearValue.depthStencil = {1.0f, 0};
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {w, h}};
  ri.layerCount = 1;
  ri.colorAttachmentCount = second ? 2 : 1;
  ri.pColorAttachments = colors;
  ri.pDepthAttachment = &da;
  vkCmdBeginRendering(cmd, &ri);
}

void full_barrier(VkCommandBuffer cmd) {
  VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  b.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &b, 0,
                       nullptr, 0, nullptr);
}

void to_general_layout(VkCommandBuffer cmd, VkImage image, const VkImageSubresourceRange& range) {
  VkImageMemoryBarrier b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  b.srcAccessMask = 0;
  b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  b.newLayout = VK_IMAGE_LAYOUT_GENERAL;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = range;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0, nullptr, 0,
                       nullptr, 1, &b);
}

Status VkBackend::record_draw(VkPipeline pipeline, VkDescriptorSet set, const VkMesh& mesh, const ShaderParams& params,
                              const Texture& color, const Texture& depth, uint32_t w, uint32_t h,
                              VkPipelineLayout layout, const Texture* second) {
  FrameContext& c = open_context();
  if (c.ubo_offset + ubo_stride_ > ubo_stride_ * options_.max_draws_per_frame) return Status::insufficient_space;
  const VkDeviceSize offset = context_ubo_base() + c.ubo_offset;
  std::memcpy(static_cast<char*>(ubo_all_.mapped) + offset, &params, sizeof(ShaderParams));
  c.ubo_offset += ubo_stride_;
  begin_rendering(c.cmd, color, depth, w, h, nullptr, second);
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

void VkBackend::clear_pass(VkCommandBuffer cmd, const Texture& color, const Texture& depth, VkClearValue value,
                           uint32_t w, uint32_t h) {
  begin_rendering(cmd, color, depth, w, h, &value);
  vkCmdEndRendering(cmd);
}

FrameContext& VkBackend::open_context() {
  FrameContext& c = contexts_[current_];
  if (!recording_) {
    if (c.serial) {
      vkWaitForFences(vk_.device, 1, &c.fence, VK_TRUE, UINT64_MAX);
      completed_serial_ = std::max(completed_serial_, c.serial);
      vkResetFences(vk_.device, 1, &c.fence);
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

bool VkBackend::submit_context() {
  FrameContext& c = contexts_[current_];
  if (vkEndCommandBuffer(c.cmd) != VK_SUCCESS) return false;
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &c.cmd;
  const bool ok = vkQueueSubmit(vk_.queue, 1, &si, c.fence) == VK_SUCCESS;
  c.serial = next_serial_++;
  recording_ = false;
  current_ = (current_ + 1) % static_cast<uint32_t>(contexts_.size());
  return ok;
}

void VkBackend::update_completed() {
  for (FrameContext& c : contexts_)
    if (c.serial > completed_serial_ && vkGetFenceStatus(vk_.device, c.fence) == VK_SUCCESS)
      completed_serial_ = c.serial;
}

VoidResult begin_one_shot_commands(VkDevice device, VkCommandPool pool, VkCommandBuffer& cmd) {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  BTFLOD_VK_CHECK(vkAllocateCommandBuffers(device, &ai, &cmd), "vkAllocateCommandBuffers");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  BTFLOD_VK_CHECK(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
  return {};
}

VoidResult submit_one_shot_commands(VkDevice device, VkQueue queue, VkCommandPool pool, VkCommandBuffer cmd) {
  VkResult r = vkEndCommandBuffer(cmd);
  if (r == VK_SUCCESS) {
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    r = vkQueueSubmit(queue, 1, &si, VK_NULL_HANDLE);
    if (r == VK_SUCCESS) r = vkQueueWaitIdle(queue);
  }
  vkFreeCommandBuffers(device, pool, 1, &cmd);
  if (r != VK_SUCCESS) return make_error(Status::io_error, "Vulkan: one-shot submit failed (%d)", static_cast<int>(r));
  return {};
}

}  // namespace btflod::samples::vk_detail
