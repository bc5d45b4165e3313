// btflod sample — headless Vulkan 1.3 backend: the laplacian, lpca and pca_views materials (paper
// 001 eq. 7, paper 002 §6.2, paper 004 §6.3): their textures in the layouts of backend.hpp, set
// layouts and pipelines. See vk_internal.hpp.
#include "vk_internal.hpp"

#include <algorithm>
#include <vector>

namespace btflod::samples::vk_detail {

Result<MaterialHandle> VkBackend::create_laplacian_material(const LaplacianMaterialData& d) {
  if (VoidResult v = check_material(d, "create_laplacian_material"); !v) return v.error();
  const uint32_t groups = (d.components + 3) / 4;
  std::vector<const void*> weight_mips;  // mip k = pyramid level k (paper 001 §3.3)
  const float* w = d.weights.data();
  for (uint32_t k = 0; k <= d.max_level; ++k) {
    weight_mips.push_back(w);
    w += static_cast<size_t>(std::max(1u, d.width >> k)) * std::max(1u, d.height >> k) * groups * 4;
  }
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
       {ShaderBinding::laplacian_mean, f4, d.light_count, d.view_count, 1, 1, 1, false, {d.mean.data()}, 16, false}},
      &d.angular);
}

Result<MaterialHandle> VkBackend::create_lpca_material(const LpcaMaterialData& d) {
  if (VoidResult v = check_material(d, "create_lpca_material"); !v) return v.error();
  const uint32_t R = d.grid_resolution;
  const VkFormat f4 = VK_FORMAT_R32G32B32A32_SFLOAT;
  // paper 002 §6.3: the eigen-BRDF volume is 8-bit; snorm8 returns q/127 and must filter
  // linearly as a 3D image (lavapipe does; checked so another driver fails here, not in a draw).
  const VkFormat volume_format = VK_FORMAT_R8G8B8A8_SNORM;
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(vk_.physical, volume_format, &fp);
  VkImageFormatProperties ifp{};
  if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) ||
      vkGetPhysicalDeviceImageFormatProperties(vk_.physical, volume_format, VK_IMAGE_TYPE_3D, VK_IMAGE_TILING_OPTIMAL,
                                               VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, 0,
                                               &ifp) != VK_SUCCESS ||
      ifp.maxExtent.width < (d.components + 1) * R || ifp.maxExtent.height < d.clusters * R ||
      ifp.maxExtent.depth < R * R)
    return make_error(Status::unsupported, "Vulkan: no linearly filtered 3D R8G8B8A8_SNORM image of %u×%u×%u",
                      (d.components + 1) * R, d.clusters * R, R * R);
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
                             // α'_j of the mean (j = 0) and the C eigen-BRDFs, 8-bit scales folded in
                             {ShaderBinding::lpca_weights,
                              f4,
                              d.width,
                              d.height,
                              (d.components + 4) / 4,
                              1,
                              1,
                              true,
                              {d.weights.data()},
                              16,
                              false},
                             // paper 002 §6.2: the eigen-BRDF volume, linear filtering in s_v, t_v, s_l
                             {ShaderBinding::lpca_volume,
                              volume_format,
                              (d.components + 1) * R,
                              d.clusters * R,
                              1,
                              1,
                              R * R,
                              false,
                              {d.volume.data()},
                              4,
                              true}});
}

Result<MaterialHandle> VkBackend::create_pca_views_material(const PcaViewsMaterialData& d) {
  if (VoidResult v = check_material(d, "create_pca_views_material"); !v) return v.error();
  const uint32_t groups = (d.view_count + d.views_per_group - 1) / d.views_per_group;
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
       {ShaderBinding::pca_r, f4, d.components, d.light_count * d.view_count, 1, 1, 1, false, {d.r.data()}, 16, false}},
      &d.angular);
}

Result<MaterialHandle> VkBackend::create_spmm_material(const SpmmMaterialData& d) {
  if (VoidResult v = check_material(d, "create_spmm_material"); !v) return v.error();
  const uint32_t rows = (d.bases + kSpmmBasesPerRow - 1) / kSpmmBasesPerRow;
  const VkFormat f4 = VK_FORMAT_R32G32B32A32_SFLOAT;
  return add_representation(ShaderProgram::spmm, representation_config(config_, d),
                            {// paper 003 eq. 1, 3: slots (basis index, α) and cluster + residual coefficients per texel
                             {ShaderBinding::spmm_texels,
                              VK_FORMAT_R32G32B32A32_UINT,
                              d.width,
                              d.height,
                              d.slots + spmm_residual_layers(d.residual_components),
                              1,
                              1,
                              true,
                              {d.texels.data()},
                              16,
                              false},
                             // eq. 2: model id, κ_j, n_j, 2 texels per basis function
                             {ShaderBinding::spmm_dictionary,
                              f4,
                              2 * kSpmmBasesPerRow,
                              rows,
                              1,
                              1,
                              1,
                              false,
                              {d.dictionary.data()},
                              16,
                              false},
                             // eq. 3: residual mean and components per cluster, texel (light, view)
                             {ShaderBinding::spmm_residual,
                              f4,
                              d.light_count,
                              d.view_count,
                              d.clusters * (d.residual_components + 1),
                              1,
                              1,
                              true,
                              {d.residual.data()},
                              16,
                              false}},
                            &d.angular);
}

Result<MaterialHandle> VkBackend::add_representation(ShaderProgram program, const ShaderConfig& config,
                                                     std::vector<RepTexture> textures,
                                                     const AngularTablesData* angular) {
  std::vector<uint32_t> index;  // the angular tables as RGBA texels (backend.hpp), while they upload
  std::vector<float> weight;
  if (angular) {
    pack_angular_tables_rgba(*angular, index, weight);
    const uint32_t res = angular->resolution;
    const struct {
      ShaderBinding binding;
      VkFormat format;
      const void* data;
    } tables[2] = {{ShaderBinding::angular_index, VK_FORMAT_R32G32B32A32_UINT, index.data()},
                   {ShaderBinding::angular_weight, VK_FORMAT_R32G32B32A32_SFLOAT, weight.data()}};
    for (const auto& t : tables)
      textures.push_back({t.binding, t.format, res, res, 2, 1, 1, true, {t.data}, 16, false});
  }
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
    BTFLOD_VK_CHECK(vkCreateDescriptorSetLayout(vk_.device, &lci, nullptr, &rep_set_layout_[kind]),
                    "vkCreateDescriptorSetLayout");
    VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    plci.setLayoutCount = 1;
    plci.pSetLayouts = &rep_set_layout_[kind];
    BTFLOD_VK_CHECK(vkCreatePipelineLayout(vk_.device, &plci, nullptr, &rep_pipeline_layout_[kind]),
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
    Result<GlslProgramSource> src = options_.hlsl_programs ? generate_hlsl_program(program, config)
                                                           : generate_program(program, GlslTarget::vulkan450, config);
    if (!src) r = src.error();
    Result<VkPipeline> p = r ? create_pipeline(*src, shader_program_name(program), VK_FORMAT_R32G32B32A32_SFLOAT,
                                               rep_pipeline_layout_[kind], VK_FORMAT_UNDEFINED, options_.hlsl_programs)
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
    if (vkAllocateDescriptorSets(vk_.device, &ai, &m.set) != VK_SUCCESS)
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
  vkUpdateDescriptorSets(vk_.device, static_cast<uint32_t>(textures.size() + 1), w, 0, nullptr);
  materials_.push_back(m);
  return MaterialHandle{static_cast<uint32_t>(materials_.size())};
}

}  // namespace btflod::samples::vk_detail
