// btflod sample — headless OpenGL 4.5 core backend (EGL surfaceless / device platform).
// See gl_backend.hpp. GL 4.5 direct state access throughout; one uniform buffer updated per
// draw; feedback read back through a ring of pixel-pack buffers guarded by fences.
#include "gl_backend.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <glad/gl.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>
#include <vector>

#include "btflod/core/half.hpp"
#include "gl_representations.hpp"
#include "gl_util.hpp"

namespace btflod::samples {
namespace {

struct GlMesh {
  GLuint vao = 0, vbo = 0, ibo = 0;
  GLsizei index_count = 0;
};

// One cache pool: its cache texture (and slot map for the affine formats) and the bsvtf
// programs generated for its tile size and format (compile-time constants of the shaders).
struct GlPool {
  VirtualTextureConfig vt;
  GLuint cache = 0, slot_map = 0, bsvtf = 0, bsvtf_feedback = 0;
};

struct GlMaterial {
  GLuint eigen_abrdfs = 0, angular_index = 0, angular_weight = 0, eigen_textures = 0;
  uint32_t pool = 0;        ///< cache pool its bsvtf draws read (FmfMaterialData::cache_pool)
  int representation = -1;  ///< index into reps_ for a laplacian / lpca / pca_views material
  uint32_t light_count = 0, view_count = 0, components = 0;  ///< FMF materials: U′'s shape
  std::vector<float> packet_layers;                          // upload_u_packets staging (4 layers of U′)
  bool live = true;                                          ///< false once destroy_material() released it
};

struct FeedbackSlot {
  GLuint pbo = 0;
  GLsync fence = nullptr;
  uint64_t frame = 0;
  uint32_t width = 0, height = 0;
  bool pending = false;  ///< holds a readback not yet returned by poll_feedback
  /// The PBO holds the full-resolution words of a bsvtf_feedback frame (this frame's desc):
  /// poll_feedback() subsamples them.
  bool full = false;
  FrameDesc desc{};
};

class GlBackend final : public Backend {
 public:
  static int& live_backends() {
    static int n = 0;
    return n;
  }

  /// `owns_context`: false for a context made by gl_window.cpp (the window destroys it and its
  /// surface; the backend then neither counts in live_backends() nor terminates the display).
  GlBackend(EGLDisplay display, EGLContext context, const GlBackendOptions& options,
            EGLSurface surface = EGL_NO_SURFACE, bool owns_context = true)
      : display_(display),
        context_(context),
        surface_(surface),
        owns_context_(owns_context),
        ring_(std::max<uint32_t>(options.feedback_ring_size, 1)) {
    if (owns_context_) ++live_backends();
    name_ = std::string("OpenGL ") + reinterpret_cast<const char*>(glGetString(GL_VERSION)) + " (" +
            reinterpret_cast<const char*>(glGetString(GL_RENDERER)) + ")";
  }

  ~GlBackend() override {
    eglMakeCurrent(display_, surface_, surface_, context_);
    for (GLuint p : {fmf_, feedback_}) glDeleteProgram(p);
    for (GlPool& p : pools_) {
      glDeleteProgram(p.bsvtf);
      glDeleteProgram(p.bsvtf_feedback);
      GLuint t[2] = {p.cache, p.slot_map};
      glDeleteTextures(2, t);
    }
    for (GlMesh& m : meshes_) {
      glDeleteVertexArrays(1, &m.vao);
      glDeleteBuffers(1, &m.vbo);
      glDeleteBuffers(1, &m.ibo);
    }
    for (GlMaterial& m : materials_) {
      GLuint t[4] = {m.eigen_abrdfs, m.angular_index, m.angular_weight, m.eigen_textures};
      glDeleteTextures(4, t);
    }
    for (GlRepresentation& r : reps_) destroy_gl_representation(r);
    for (FeedbackSlot& s : ring_) {
      if (s.fence) glDeleteSync(s.fence);
      glDeleteBuffers(1, &s.pbo);
    }
    destroy_targets();
    glDeleteTextures(1, &page_table_);
    glDeleteBuffers(1, &ubo_);
    if (!owns_context_) return;  // the window keeps its context current until it destroys it
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    // EGL displays are per-process singletons: terminate only when the last backend goes.
    if (--live_backends() == 0) eglTerminate(display_);
  }

  const char* name() const noexcept override { return name_.c_str(); }

  VoidResult init(const ShaderConfig& config, uint32_t virtual_texture_count) override {
    make_current();
    if (VoidResult v = validate_shader_config(config); !v) return v;
    if (virtual_texture_count == 0 || virtual_texture_count > 2048)
      return make_error(Status::invalid_argument, "GL: %u virtual textures, expected 1..2048", virtual_texture_count);
    config_ = config;
    vt_layers_ = virtual_texture_count;
    const ShaderProgram programs[2] = {ShaderProgram::fmf, ShaderProgram::feedback};
    GLuint* out[2] = {&fmf_, &feedback_};
    for (int i = 0; i < 2; ++i) {
      Result<GLuint> prog = compile_program(programs[i], config);
      if (!prog) return prog.error();
      *out[i] = *prog;
    }
    const VirtualTextureConfig& vt = config.vt;
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    if ((1u << vt.finest_level) > static_cast<uint32_t>(max_size))
      return make_error(Status::unsupported, "GL: page table 2^%u exceeds the limits (%d)", vt.finest_level, max_size);
    pools_.emplace_back();
    if (VoidResult v = create_pool(config, pools_.back()); !v) return v;
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &page_table_);
    const GLsizei side = 1 << vt.finest_level;
    glTextureStorage3D(page_table_, static_cast<GLsizei>(vt.finest_level + 1), GL_R32UI, side, side,
                       static_cast<GLsizei>(virtual_texture_count));
    glTextureParameteri(page_table_, GL_TEXTURE_MIN_FILTER, GL_NEAREST_MIPMAP_NEAREST);
    glTextureParameteri(page_table_, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    const GLuint zero_entry = 0;
    for (uint32_t m = 0; m <= vt.finest_level; ++m)
      glClearTexImage(page_table_, static_cast<GLint>(m), GL_RED_INTEGER, GL_UNSIGNED_INT, &zero_entry);
    glCreateBuffers(1, &ubo_);
    glNamedBufferStorage(ubo_, sizeof(ShaderParams), nullptr, GL_DYNAMIC_STORAGE_BIT);
    for (FeedbackSlot& s : ring_) glCreateBuffers(1, &s.pbo);
    if (GLenum e = glGetError(); e != GL_NO_ERROR)
      return make_error(Status::unsupported, "GL: error 0x%04x while creating the cache and page table", e);
    initialised_ = true;
    return {};
  }

  Result<uint32_t> add_cache_pool(const CacheConfig& cache) override {
    make_current();
    if (!initialised_) return make_error(Status::invalid_argument, "GL: add_cache_pool before init");
    if (pools_.size() >= kMaxCachePools)
      return make_error(Status::invalid_argument, "GL: %zu cache pools already, at most %u", pools_.size(),
                        kMaxCachePools);
    ShaderConfig c = config_;
    static_cast<CacheConfig&>(c.vt) = cache;
    if (VoidResult v = validate_shader_config(c); !v) return v.error();
    GlPool pool;
    if (VoidResult v = create_pool(c, pool); !v) {
      glDeleteProgram(pool.bsvtf);
      glDeleteProgram(pool.bsvtf_feedback);
      GLuint t[2] = {pool.cache, pool.slot_map};
      glDeleteTextures(2, t);
      return v.error();
    }
    pools_.push_back(pool);
    return static_cast<uint32_t>(pools_.size() - 1);
  }

  uint32_t cache_pool_count() const noexcept override { return static_cast<uint32_t>(pools_.size()); }

  // The bsvtf programs and the cache texture (and slot map) of config.vt's cache shape.
  VoidResult create_pool(const ShaderConfig& config, GlPool& pool) {
    const VirtualTextureConfig& vt = config.vt;
    pool.vt = vt;
    Result<GLuint> bsvtf = compile_program(ShaderProgram::bsvtf, config);
    if (!bsvtf) return bsvtf.error();
    pool.bsvtf = *bsvtf;
    Result<GLuint> words = compile_program(ShaderProgram::bsvtf_feedback, config);
    if (!words) return words.error();
    pool.bsvtf_feedback = *words;
    GLint max_size = 0, max_layers = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
    if (vt.cache_width() > static_cast<uint32_t>(max_size) || vt.cache_height() > static_cast<uint32_t>(max_size) ||
        vt.cache_layers * (vt.format == CacheFormat::bc5_affine ? 2u : 1u) > static_cast<uint32_t>(max_layers))
      return make_error(Status::unsupported, "GL: cache %u×%u×%u exceeds the limits (%d, %d layers)", vt.cache_width(),
                        vt.cache_height(), vt.cache_layers, max_size, max_layers);
    GLuint& cache_tex = pool.cache;
    GLuint& map_tex = pool.slot_map;
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &cache_tex);
    const bool affine = cache_format_has_slot_map(vt.format);
    const bool bc5 = vt.format == CacheFormat::bc5_affine;
    // bc5_affine: two RGTC2 planes per cache layer, plane p of layer L at array layer 2L + p
    // (runtime/vt/cache_bc5.hpp; the shaders read both).
    glTextureStorage3D(cache_tex, 1,
                       bc5                                      ? GL_COMPRESSED_RG_RGTC2
                       : vt.format == CacheFormat::rgba8_affine ? GL_RGBA8
                                                                : GL_RGBA16F,
                       static_cast<GLsizei>(vt.cache_width()), static_cast<GLsizei>(vt.cache_height()),
                       static_cast<GLsizei>(vt.cache_layers * (bc5 ? 2 : 1)));
    glTextureParameteri(cache_tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(cache_tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(cache_tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(cache_tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    if (bc5) {  // glClearTexImage takes no compressed texture: all-zero blocks decode to 0
      const std::vector<uint8_t> zero_blocks(static_cast<size_t>(vt.cache_width()) * vt.cache_height() * 2 *
                                             vt.cache_layers);
      glCompressedTextureSubImage3D(cache_tex, 0, 0, 0, 0, static_cast<GLsizei>(vt.cache_width()),
                                    static_cast<GLsizei>(vt.cache_height()), static_cast<GLsizei>(vt.cache_layers * 2),
                                    GL_COMPRESSED_RG_RGTC2, static_cast<GLsizei>(zero_blocks.size()),
                                    zero_blocks.data());
    } else {
      const float zero[4] = {0, 0, 0, 0};
      glClearTexImage(cache_tex, 0, GL_RGBA, GL_FLOAT, zero);
    }
    if (affine) {  // one RGBA32UI texel per slot: offsets and scales as halves (runtime/vt/cache_format.hpp)
      glCreateTextures(GL_TEXTURE_2D, 1, &map_tex);
      glTextureStorage2D(map_tex, 1, GL_RGBA32UI, static_cast<GLsizei>(cache_slot_map_width(vt)),
                         static_cast<GLsizei>(cache_slot_map_height(vt)));
      glTextureParameteri(map_tex, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTextureParameteri(map_tex, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      const GLuint zero_map[4] = {0, 0, 0, 0};
      glClearTexImage(map_tex, 0, GL_RGBA_INTEGER, GL_UNSIGNED_INT, zero_map);
    }
    if (GLenum e = glGetError(); e != GL_NO_ERROR)
      return make_error(Status::unsupported, "GL: error 0x%04x while creating a tile cache", e);
    return {};
  }

  static Result<GLuint> compile_program(ShaderProgram program, const ShaderConfig& config) {
    Result<GlslProgramSource> src = generate_program(program, GlslTarget::gl450_core, config);
    if (!src) return src.error();
    return compile_gl_program(*src, shader_program_name(program));
  }

  Result<MeshHandle> create_mesh(const MeshData& mesh) override {
    make_current();
    if (VoidResult v = validate_mesh(mesh); !v) return v.error();
    GlMesh m;
    glCreateBuffers(1, &m.vbo);
    glNamedBufferStorage(m.vbo, static_cast<GLsizeiptr>(mesh.vertices.size_bytes()), mesh.vertices.data(), 0);
    glCreateBuffers(1, &m.ibo);
    glNamedBufferStorage(m.ibo, static_cast<GLsizeiptr>(mesh.indices.size_bytes()), mesh.indices.data(), 0);
    glCreateVertexArrays(1, &m.vao);
    glVertexArrayVertexBuffer(m.vao, 0, m.vbo, 0, sizeof(MeshVertex));
    glVertexArrayElementBuffer(m.vao, m.ibo);
    const struct {
      VertexAttribute a;
      GLint n;
      GLuint off;
    } attrs[4] = {{VertexAttribute::position, 3, offsetof(MeshVertex, position)},
                  {VertexAttribute::normal, 3, offsetof(MeshVertex, normal)},
                  {VertexAttribute::tangent, 4, offsetof(MeshVertex, tangent)},
                  {VertexAttribute::uv, 2, offsetof(MeshVertex, uv)}};
    for (const auto& a : attrs) {
      const GLuint loc = static_cast<GLuint>(a.a);
      glEnableVertexArrayAttrib(m.vao, loc);
      glVertexArrayAttribFormat(m.vao, loc, a.n, GL_FLOAT, GL_FALSE, a.off);
      glVertexArrayAttribBinding(m.vao, loc, 0);
    }
    m.index_count = static_cast<GLsizei>(mesh.indices.size());
    meshes_.push_back(m);
    return MeshHandle{static_cast<uint32_t>(meshes_.size())};
  }

  Result<MaterialHandle> create_material(const FmfMaterialData& data) override {
    make_current();
    if (!initialised_) return make_error(Status::invalid_argument, "GL: create_material before init");
    if (VoidResult v = validate_material(data, config_); !v) return v.error();
    if (data.cache_pool >= pools_.size())
      return make_error(Status::invalid_argument, "GL: the material names cache pool %u of %zu", data.cache_pool,
                        pools_.size());
    GlMaterial m;
    m.pool = data.cache_pool;
    const std::vector<float> u = pack_eigen_abrdfs_rgba(data);
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &m.eigen_abrdfs);
    glTextureStorage3D(m.eigen_abrdfs, 1, GL_RGBA32F, static_cast<GLsizei>(data.light_count),
                       static_cast<GLsizei>(data.view_count), static_cast<GLsizei>(data.components));
    glTextureSubImage3D(m.eigen_abrdfs, 0, 0, 0, 0, static_cast<GLsizei>(data.light_count),
                        static_cast<GLsizei>(data.view_count), static_cast<GLsizei>(data.components), GL_RGBA, GL_FLOAT,
                        u.data());
    set_gl_sampling(m.eigen_abrdfs, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
    m.light_count = data.light_count;
    m.view_count = data.view_count;
    m.components = data.components;
    m.packet_layers.assign(size_t{data.light_count} * data.view_count * 4 * std::min(4u, data.components), 0.0f);
    const GlAngularTables tables = create_gl_angular_tables(data.angular);
    m.angular_index = tables.index;
    m.angular_weight = tables.weight;
    if (!data.eigen_textures.empty()) {
      const std::vector<float> v = pack_eigen_textures_rgba(data.eigen_textures);
      const GLsizei w = data.eigen_textures.width(), h = data.eigen_textures.height();
      GLsizei levels = 1;
      if (data.mipmaps)
        while ((std::max(w, h) >> levels) > 0) ++levels;
      glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &m.eigen_textures);
      glTextureStorage3D(m.eigen_textures, levels, GL_RGBA32F, w, h, static_cast<GLsizei>((data.components + 3) / 4));
      glTextureSubImage3D(m.eigen_textures, 0, 0, 0, 0, w, h, static_cast<GLsizei>((data.components + 3) / 4), GL_RGBA,
                          GL_FLOAT, v.data());
      if (levels > 1) glGenerateTextureMipmap(m.eigen_textures);
      glTextureParameteri(m.eigen_textures, GL_TEXTURE_MIN_FILTER, levels > 1 ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR);
      glTextureParameteri(m.eigen_textures, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTextureParameteri(m.eigen_textures, GL_TEXTURE_WRAP_S, GL_REPEAT);
      glTextureParameteri(m.eigen_textures, GL_TEXTURE_WRAP_T, GL_REPEAT);
    }
    if (GLenum e = glGetError(); e != GL_NO_ERROR)
      return make_error(Status::unsupported, "GL: error 0x%04x while creating a material", e);
    materials_.push_back(std::move(m));
    return MaterialHandle{static_cast<uint32_t>(materials_.size())};
  }

  Status destroy_material(MaterialHandle material) override {
    make_current();
    if (material.id == 0 || material.id > materials_.size() || !materials_[material.id - 1].live)
      return Status::invalid_argument;
    GlMaterial& m = materials_[material.id - 1];
    // GL keeps a deleted texture alive for the commands already issued that read it.
    GLuint t[4] = {m.eigen_abrdfs, m.angular_index, m.angular_weight, m.eigen_textures};
    glDeleteTextures(4, t);
    if (m.representation >= 0) destroy_gl_representation(reps_[static_cast<size_t>(m.representation)]);
    m = GlMaterial{};
    m.live = false;
    return Status::success;
  }

  Result<MaterialHandle> create_laplacian_material(const LaplacianMaterialData& data) override {
    return add_representation(data);
  }
  Result<MaterialHandle> create_lpca_material(const LpcaMaterialData& data) override {
    return add_representation(data);
  }
  Result<MaterialHandle> create_pca_views_material(const PcaViewsMaterialData& data) override {
    return add_representation(data);
  }
  Result<MaterialHandle> create_spmm_material(const SpmmMaterialData& data) override {
    return add_representation(data);
  }

  Status upload_tiles(std::span<const TileUpload> tiles) noexcept override {
    make_current();
    if (!initialised_) return Status::invalid_argument;
    for (const TileUpload& t : tiles)
      if (t.pool >= pools_.size() || check_tile_upload(t, pools_[t.pool].vt) != Status::success)
        return Status::invalid_argument;
    for (const TileUpload& t : tiles) {
      // Each tile into its pool's cache texture, in that pool's shape and format.
      const GlPool& pool = pools_[t.pool];
      const VirtualTextureConfig& vt = pool.vt;
      const GLuint cache_tex = pool.cache, map_tex = pool.slot_map;
      const size_t padded = vt.padded_tile_size();
      const bool affine = cache_format_has_slot_map(vt.format);
      const bool bc5 = vt.format == CacheFormat::bc5_affine;
      const size_t plane_bytes = padded * padded;  // BC5: 16 bytes per 4 × 4 texels
      const SlotPlacement p = slot_placement(vt, t.slot);
      if (bc5) {
        for (uint32_t plane = 0; plane < 2; ++plane)  // plane p of layer L at array layer 2L + p
          glCompressedTextureSubImage3D(cache_tex, 0, static_cast<GLint>(p.x), static_cast<GLint>(p.y),
                                        static_cast<GLint>(2 * p.layer + plane), static_cast<GLsizei>(padded),
                                        static_cast<GLsizei>(padded), 1, GL_COMPRESSED_RG_RGTC2,
                                        static_cast<GLsizei>(plane_bytes), t.bc5.data() + plane * plane_bytes);
      } else {
        glTextureSubImage3D(cache_tex, 0, static_cast<GLint>(p.x), static_cast<GLint>(p.y), static_cast<GLint>(p.layer),
                            static_cast<GLsizei>(padded), static_cast<GLsizei>(padded), 1, GL_RGBA,
                            affine ? GL_UNSIGNED_BYTE : GL_HALF_FLOAT,
                            affine ? static_cast<const void*>(t.unorm8.data()) : t.texels.data());
      }
      if (affine) {
        const CacheSlotMapTexel m = cache_slot_map_texel(vt, t.slot);
        const std::array<uint32_t, 4> packed = pack_cache_slot_map(t.map);
        glTextureSubImage2D(map_tex, 0, static_cast<GLint>(m.x), static_cast<GLint>(m.y), 1, 1, GL_RGBA_INTEGER,
                            GL_UNSIGNED_INT, packed.data());
      }
    }
    return Status::success;
  }

  Status upload_u_packets(MaterialHandle material, std::span<const UPacketUpload> packets) noexcept override {
    make_current();
    if (!initialised_ || material.id == 0 || material.id > materials_.size()) return Status::invalid_argument;
    GlMaterial& m = materials_[material.id - 1];
    if (!m.live || m.representation >= 0 || m.components == 0) return Status::invalid_argument;
    for (const UPacketUpload& p : packets)
      if (check_u_packet(p, m.light_count, m.view_count, m.components) != Status::success)
        return Status::invalid_argument;
    for (const UPacketUpload& p : packets) {
      // Client memory is copied by glTextureSubImage3D before it returns: one staging buffer.
      const uint32_t n = u_packet_to_rgba_layers(p, m.light_count, m.view_count, m.components, m.packet_layers);
      glTextureSubImage3D(m.eigen_abrdfs, 0, 0, 0, static_cast<GLint>(4 * p.packet),
                          static_cast<GLsizei>(m.light_count), static_cast<GLsizei>(m.view_count),
                          static_cast<GLsizei>(n), GL_RGBA, GL_FLOAT, m.packet_layers.data());
    }
    return Status::success;
  }

  Status apply_page_table_writes(std::span<const PageTableWrite> writes) noexcept override {
    make_current();
    if (!initialised_) return Status::invalid_argument;
    if (Status s = check_page_table_writes(writes, vt_layers_, config_.vt.finest_level); s != Status::success) return s;
    for (const PageTableWrite& d : writes)
      glTextureSubImage3D(page_table_, static_cast<GLint>(d.page_mip), static_cast<GLint>(d.tile.x),
                          static_cast<GLint>(d.tile.y), static_cast<GLint>(d.tile.texture), 1, 1, 1, GL_RED_INTEGER,
                          GL_UNSIGNED_INT, &d.entry);
    return Status::success;
  }

  Status begin_frame(const FrameDesc& frame) noexcept override {
    make_current();
    if (!initialised_ || frame.width == 0 || frame.height == 0 || frame.feedback_width == 0 ||
        frame.feedback_height == 0 || frame.width > 16384 || frame.height > 16384 ||
        frame.feedback_sample_x >= frame.feedback_block_width() ||
        frame.feedback_sample_y >= frame.feedback_block_height())
      return Status::invalid_argument;
    if (frame.width != frame_.width || frame.height != frame_.height || frame.feedback_width != frame_.feedback_width ||
        frame.feedback_height != frame_.feedback_height || !color_fbo_) {
      destroy_targets();
      frame_ = frame;
      create_targets();  // set-up work: only when the size changes
    }
    frame_ = frame;
    glClearNamedFramebufferfv(color_fbo_, GL_COLOR, 0, frame.clear_color);
    const float one = 1.0f;
    glClearNamedFramebufferfv(color_fbo_, GL_DEPTH, 0, &one);
    const GLuint empty[4] = {config_.vt.feedback.empty_word, 0, 0, 0};
    glClearNamedFramebufferuiv(feedback_fbo_, GL_COLOR, 0, empty);
    glClearNamedFramebufferfv(feedback_fbo_, GL_DEPTH, 0, &one);
    feedback_drawn_ = false;
    feedback_stored_ = false;
    return Status::success;
  }

  Status draw(ShaderProgram program, MeshHandle mesh, MaterialHandle material,
              const ShaderParams& params) noexcept override {
    if (!color_fbo_ || mesh.id == 0 || mesh.id > meshes_.size() || material.id == 0 || material.id > materials_.size())
      return Status::invalid_argument;
    const GlMaterial& m = materials_[material.id - 1];
    if (!m.live) return Status::invalid_argument;
    if (m.representation >= 0) {  // laplacian / lpca / pca_views (gl_representations.cpp)
      const GlRepresentation& r = reps_[static_cast<size_t>(m.representation)];
      if (r.program != program) return Status::invalid_argument;
      glBindFramebuffer(GL_FRAMEBUFFER, color_fbo_);
      glViewport(0, 0, static_cast<GLsizei>(frame_.width), static_cast<GLsizei>(frame_.height));
      bind_gl_representation(r);
      submit_draw(meshes_[mesh.id - 1], params);
      return Status::success;
    }
    GLuint prog = 0;
    if (program == ShaderProgram::fmf) {
      if (!m.eigen_textures) return Status::invalid_argument;  // BSVTF-only material
      prog = fmf_;
    } else if (program == ShaderProgram::bsvtf) {
      prog = pools_[m.pool].bsvtf;
    } else if (program == ShaderProgram::bsvtf_feedback) {
      prog = pools_[m.pool].bsvtf_feedback;
    } else {
      return Status::invalid_argument;
    }
    const bool words = program == ShaderProgram::bsvtf_feedback;
    glBindFramebuffer(GL_FRAMEBUFFER, words ? color_feedback_fbo_ : color_fbo_);
    glViewport(0, 0, static_cast<GLsizei>(frame_.width), static_cast<GLsizei>(frame_.height));
    glUseProgram(prog);
    bind(ShaderBinding::eigen_abrdfs, m.eigen_abrdfs);
    bind(ShaderBinding::angular_index, m.angular_index);
    bind(ShaderBinding::angular_weight, m.angular_weight);
    if (program == ShaderProgram::fmf) {
      bind(ShaderBinding::eigen_textures, m.eigen_textures);
    } else {
      // The material's pool: its cache texture (and slot map) with the page table all pools share.
      bind(ShaderBinding::tile_cache, pools_[m.pool].cache);
      bind(ShaderBinding::page_table, page_table_);
      if (pools_[m.pool].slot_map) bind(ShaderBinding::slot_map, pools_[m.pool].slot_map);
    }
    if (words) {
      // Colour and every pixel's feedback word (fragment output 1). The word target is cleared
      // by the frame's first such draw only: frames without one never touch it.
      if (!feedback_stored_) {
        const GLuint empty[4] = {config_.vt.feedback.empty_word, 0, 0, 0};
        glClearNamedFramebufferuiv(color_feedback_fbo_, GL_COLOR, 1, empty);
      }
      feedback_drawn_ = feedback_stored_ = true;
    }
    submit_draw(meshes_[mesh.id - 1], params_for_material(params, m.components));
    return Status::success;
  }

  Status draw_feedback(MeshHandle mesh, const ShaderParams& params) noexcept override {
    if (!feedback_fbo_ || mesh.id == 0 || mesh.id > meshes_.size()) return Status::invalid_argument;
    glBindFramebuffer(GL_FRAMEBUFFER, feedback_fbo_);
    glViewport(0, 0, static_cast<GLsizei>(frame_.feedback_width), static_cast<GLsizei>(frame_.feedback_height));
    glUseProgram(feedback_);
    bind(ShaderBinding::page_table, page_table_);
    submit_draw(meshes_[mesh.id - 1], params);
    feedback_drawn_ = true;
    return Status::success;
  }

  Status end_frame() noexcept override {
    if (!color_fbo_) return Status::invalid_argument;
    if (feedback_drawn_) {
      // Ring full of unconsumed readbacks: drop the oldest (never wait for the GPU).
      FeedbackSlot* slot = nullptr;
      for (FeedbackSlot& s : ring_)
        if (!s.pending) {
          slot = &s;
          break;
        }
      if (!slot) {
        slot = &*std::min_element(ring_.begin(), ring_.end(),
                                  [](const FeedbackSlot& a, const FeedbackSlot& b) { return a.frame < b.frame; });
        release(*slot);
        ++dropped_;
      }
      // A bsvtf_feedback frame reads back every pixel's word (a plain copy, subsampled in
      // poll_feedback), any other the feedback target.
      const uint32_t w = feedback_stored_ ? frame_.width : frame_.feedback_width;
      const uint32_t h = feedback_stored_ ? frame_.height : frame_.feedback_height;
      const size_t bytes = static_cast<size_t>(w) * h * 4;
      if (slot_capacity(*slot) < bytes) {
        glNamedBufferData(slot->pbo, static_cast<GLsizeiptr>(bytes), nullptr, GL_STREAM_READ);  // resize only
      }
      glBindBuffer(GL_PIXEL_PACK_BUFFER, slot->pbo);
      glBindFramebuffer(GL_READ_FRAMEBUFFER, feedback_stored_ ? color_feedback_fbo_ : feedback_fbo_);
      glReadBuffer(feedback_stored_ ? GL_COLOR_ATTACHMENT1 : GL_COLOR_ATTACHMENT0);
      glPixelStorei(GL_PACK_ALIGNMENT, 4);
      glReadPixels(0, 0, static_cast<GLsizei>(w), static_cast<GLsizei>(h), GL_RED_INTEGER, GL_UNSIGNED_INT, nullptr);
      slot->full = feedback_stored_;
      slot->desc = frame_;
      glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
      slot->fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
      slot->frame = frame_counter_;
      slot->width = frame_.feedback_width;
      slot->height = frame_.feedback_height;
      slot->pending = true;
    }
    glFlush();
    ++frame_counter_;
    return glGetError() == GL_NO_ERROR ? Status::success : Status::io_error;
  }

  bool poll_feedback(FeedbackFrame& out) noexcept override {
    make_current();
    FeedbackSlot* oldest = nullptr;
    for (FeedbackSlot& s : ring_)
      if (s.pending && (!oldest || s.frame < oldest->frame)) oldest = &s;
    if (!oldest) return false;
    const GLenum r = glClientWaitSync(oldest->fence, GL_SYNC_FLUSH_COMMANDS_BIT, 0);  // timeout 0: poll
    if (r != GL_ALREADY_SIGNALED && r != GL_CONDITION_SATISFIED) return false;
    const size_t n = static_cast<size_t>(oldest->width) * oldest->height;
    if (readback_.size() < n) readback_.resize(n);  // grows to the largest feedback size once
    const size_t mapped = oldest->full ? static_cast<size_t>(oldest->desc.width) * oldest->desc.height : n;
    const uint32_t* src = static_cast<const uint32_t*>(
        glMapNamedBufferRange(oldest->pbo, 0, static_cast<GLsizeiptr>(mapped * 4), GL_MAP_READ_BIT));
    if (!src) return false;
    if (oldest->full)  // GL rows are bottom-up; FeedbackFrame is top-down
      subsample_feedback(std::span<const uint32_t>(src, mapped), true, oldest->desc, config_.vt.feedback.empty_word,
                         std::span<uint32_t>(readback_.data(), n));
    else
      for (uint32_t y = 0; y < oldest->height; ++y)
        std::memcpy(readback_.data() + static_cast<size_t>(y) * oldest->width,
                    src + static_cast<size_t>(oldest->height - 1 - y) * oldest->width, oldest->width * 4u);
    glUnmapNamedBuffer(oldest->pbo);
    out.frame = oldest->frame;
    out.width = oldest->width;
    out.height = oldest->height;
    out.words = std::span<const uint32_t>(readback_.data(), n);
    release(*oldest);
    return true;
  }

  uint32_t feedback_ring_size() const noexcept override { return static_cast<uint32_t>(ring_.size()); }
  uint64_t dropped_feedback() const noexcept override { return dropped_; }

  Status read_color(ImageView<float> out) noexcept override {
    make_current();
    if (!color_fbo_ || out.width() != static_cast<int>(frame_.width) ||
        out.height() != static_cast<int>(frame_.height) || out.channels() != 4)
      return Status::invalid_argument;
    const size_t row = static_cast<size_t>(frame_.width) * 4;
    if (color_staging_.size() < row * frame_.height) color_staging_.resize(row * frame_.height);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, color_fbo_);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, static_cast<GLsizei>(frame_.width), static_cast<GLsizei>(frame_.height), GL_RGBA, GL_FLOAT,
                 color_staging_.data());
    for (uint32_t y = 0; y < frame_.height; ++y)
      for (uint32_t x = 0; x < frame_.width; ++x)
        for (int c = 0; c < 4; ++c)
          out.at(static_cast<int>(x), static_cast<int>(y), c) =
              color_staging_[(frame_.height - 1 - y) * row + x * 4 + static_cast<size_t>(c)];
    return glGetError() == GL_NO_ERROR ? Status::success : Status::io_error;
  }

  Status wait_idle() noexcept override {
    make_current();
    glFinish();
    return Status::success;
  }

  /// The last frame's colour target, scaled to the current surface's default framebuffer
  /// (linear → sRGB when that framebuffer is sRGB-capable). For gl_window.cpp.
  Status blit_to_default_framebuffer(uint32_t width, uint32_t height) noexcept {
    make_current();
    if (!color_fbo_ || width == 0 || height == 0) return Status::invalid_argument;
    glEnable(GL_FRAMEBUFFER_SRGB);
    glBlitNamedFramebuffer(color_fbo_, 0, 0, 0, static_cast<GLint>(frame_.width), static_cast<GLint>(frame_.height), 0,
                           0, static_cast<GLint>(width), static_cast<GLint>(height), GL_COLOR_BUFFER_BIT, GL_LINEAR);
    glDisable(GL_FRAMEBUFFER_SRGB);
    return glGetError() == GL_NO_ERROR ? Status::success : Status::io_error;
  }

 private:
  /// Several backends may live on one thread: each entry point except draw, draw_feedback and
  /// end_frame (which follow begin_frame) makes this context current (cheap when it already is).
  void make_current() {
    if (eglGetCurrentContext() != context_) eglMakeCurrent(display_, surface_, surface_, context_);
  }

  template <class Data>
  Result<MaterialHandle> add_representation(const Data& data) {
    make_current();
    if (!initialised_) return make_error(Status::invalid_argument, "GL: create_*_material before init");
    if (VoidResult v = validate_material(data, config_); !v) return v.error();
    Result<GlRepresentation> r = create_gl_representation(config_, data);
    if (!r) return r.error();
    reps_.push_back(*r);
    GlMaterial m;
    m.representation = static_cast<int>(reps_.size() - 1);
    materials_.push_back(m);
    return MaterialHandle{static_cast<uint32_t>(materials_.size())};
  }

  static void bind(ShaderBinding b, GLuint tex) { glBindTextureUnit(static_cast<GLuint>(b), tex); }

  void submit_draw(const GlMesh& mesh, const ShaderParams& params) {
    glNamedBufferSubData(ubo_, 0, sizeof(ShaderParams), &params);
    glBindBufferBase(GL_UNIFORM_BUFFER, static_cast<GLuint>(ShaderBinding::params), ubo_);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LEQUAL);
    glDisable(GL_CULL_FACE);
    glBindVertexArray(mesh.vao);
    glDrawElements(GL_TRIANGLES, mesh.index_count, GL_UNSIGNED_INT, nullptr);
  }

  static size_t slot_capacity(const FeedbackSlot& s) {
    GLint64 size = 0;
    glGetNamedBufferParameteri64v(s.pbo, GL_BUFFER_SIZE, &size);
    return static_cast<size_t>(size);
  }

  static void release(FeedbackSlot& s) {
    if (s.fence) glDeleteSync(s.fence);
    s.fence = nullptr;
    s.pending = false;
  }

  void create_targets() {
    auto make_fbo = [](GLenum color_format, uint32_t w, uint32_t h, GLuint& fbo, GLuint& color, GLuint& depth) {
      glCreateTextures(GL_TEXTURE_2D, 1, &color);
      glTextureStorage2D(color, 1, color_format, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
      glCreateRenderbuffers(1, &depth);
      glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT24, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
      glCreateFramebuffers(1, &fbo);
      glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, color, 0);
      glNamedFramebufferRenderbuffer(fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    };
    make_fbo(GL_RGBA32F, frame_.width, frame_.height, color_fbo_, color_tex_, color_depth_);
    make_fbo(GL_R32UI, frame_.feedback_width, frame_.feedback_height, feedback_fbo_, feedback_tex_, feedback_depth_);
    // bsvtf_feedback: the colour target and depth of color_fbo_ plus every pixel's word.
    glCreateTextures(GL_TEXTURE_2D, 1, &feedback_full_tex_);
    glTextureStorage2D(feedback_full_tex_, 1, GL_R32UI, static_cast<GLsizei>(frame_.width),
                       static_cast<GLsizei>(frame_.height));
    glCreateFramebuffers(1, &color_feedback_fbo_);
    glNamedFramebufferTexture(color_feedback_fbo_, GL_COLOR_ATTACHMENT0, color_tex_, 0);
    glNamedFramebufferTexture(color_feedback_fbo_, GL_COLOR_ATTACHMENT1, feedback_full_tex_, 0);
    glNamedFramebufferRenderbuffer(color_feedback_fbo_, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, color_depth_);
    const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(color_feedback_fbo_, 2, both);
  }

  void destroy_targets() {
    GLuint fbos[2] = {color_fbo_, feedback_fbo_};
    GLuint texs[2] = {color_tex_, feedback_tex_};
    GLuint rbs[2] = {color_depth_, feedback_depth_};
    glDeleteFramebuffers(2, fbos);
    glDeleteTextures(2, texs);
    glDeleteRenderbuffers(2, rbs);
    glDeleteFramebuffers(1, &color_feedback_fbo_);
    glDeleteTextures(1, &feedback_full_tex_);
    color_fbo_ = feedback_fbo_ = color_tex_ = feedback_tex_ = color_depth_ = feedback_depth_ = 0;
    color_feedback_fbo_ = feedback_full_tex_ = 0;
  }

  EGLDisplay display_;
  EGLContext context_;
  EGLSurface surface_;  // EGL_NO_SURFACE when headless
  bool owns_context_;
  std::string name_;
  ShaderConfig config_;
  uint32_t vt_layers_ = 0;
  bool initialised_ = false;
  GLuint fmf_ = 0, feedback_ = 0;
  std::vector<GlPool> pools_;  // pool 0: init()'s config.vt; then add_cache_pool()'s
  GLuint page_table_ = 0, ubo_ = 0;
  GLuint color_fbo_ = 0, color_tex_ = 0, color_depth_ = 0;
  GLuint feedback_fbo_ = 0, feedback_tex_ = 0, feedback_depth_ = 0;
  GLuint color_feedback_fbo_ = 0, feedback_full_tex_ = 0;
  FrameDesc frame_{0, 0, 0, 0, {0, 0, 0, 0}};
  bool feedback_drawn_ = false;
  bool feedback_stored_ = false;  ///< bsvtf_feedback drawn this frame: its words replace the feedback pass
  uint64_t frame_counter_ = 0;
  uint64_t dropped_ = 0;
  std::vector<GlMesh> meshes_;
  std::vector<GlMaterial> materials_;
  std::vector<GlRepresentation> reps_;
  std::vector<FeedbackSlot> ring_;
  std::vector<uint32_t> readback_;
  std::vector<float> color_staging_;
};

EGLDisplay open_display(std::string& why) {
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) {
    why = "eglGetPlatformDisplayEXT missing (no EGL_EXT_platform_base)";
    return EGL_NO_DISPLAY;
  }
  // Surfaceless first (Mesa: llvmpipe without X or a GPU), then the device platform.
  EGLDisplay d = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor)) return d;
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  if (query_devices) {
    EGLDeviceEXT devices[8];
    EGLint count = 0;
    if (query_devices(8, devices, &count))
      for (EGLint i = 0; i < count; ++i) {
        d = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor)) return d;
      }
  }
  why = "no EGL display on the surfaceless or device platform";
  return EGL_NO_DISPLAY;
}

}  // namespace

Result<std::unique_ptr<Backend>> create_gl_backend(const GlBackendOptions& options) {
  std::string why;
  EGLDisplay display = open_display(why);
  if (display == EGL_NO_DISPLAY) return make_error(Status::unsupported, "GL backend: %s", why.c_str());
  // Failure paths below leave the display initialised: another backend may be using it.
  if (!eglBindAPI(EGL_OPENGL_API)) {
    return make_error(Status::unsupported, "GL backend: eglBindAPI(EGL_OPENGL_API) failed");
  }
  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  eglChooseConfig(display, config_attribs, &config, 1, &count);  // may be 0: EGL_KHR_no_config_context
  const EGLint context_attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext context =
      eglCreateContext(display, count > 0 ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT) {
    return make_error(Status::unsupported, "GL backend: no OpenGL 4.5 core context (EGL error 0x%04x)", eglGetError());
  }
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    eglDestroyContext(display, context);
    return make_error(Status::unsupported, "GL backend: eglMakeCurrent without surface failed (0x%04x)", eglGetError());
  }
  if (!gladLoadGL(reinterpret_cast<GLADloadfunc>(eglGetProcAddress)) || !GLAD_GL_VERSION_4_5) {
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display, context);
    return make_error(Status::unsupported, "GL backend: could not load OpenGL 4.5 entry points");
  }
  return std::unique_ptr<Backend>(new GlBackend(display, context, options));
}

Result<std::unique_ptr<Backend>> create_gl_backend_on(const GlExternalContext& ctx, const GlBackendOptions& options) {
  const EGLDisplay display = static_cast<EGLDisplay>(ctx.display);
  const EGLContext context = static_cast<EGLContext>(ctx.context);
  const EGLSurface surface = ctx.surface ? static_cast<EGLSurface>(ctx.surface) : EGL_NO_SURFACE;
  if (display == EGL_NO_DISPLAY || context == EGL_NO_CONTEXT)
    return make_error(Status::invalid_argument, "GL backend: no EGL display or context given");
  if (!eglMakeCurrent(display, surface, surface, context))
    return make_error(Status::unsupported, "GL backend: eglMakeCurrent on the given surface failed (0x%04x)",
                      eglGetError());
  if (!gladLoadGL(reinterpret_cast<GLADloadfunc>(eglGetProcAddress)) || !GLAD_GL_VERSION_4_5)
    return make_error(Status::unsupported, "GL backend: could not load OpenGL 4.5 entry points");
  return std::unique_ptr<Backend>(new GlBackend(display, context, options, surface, false));
}

Status gl_blit_color_to_default_framebuffer(Backend& backend, uint32_t width, uint32_t height) noexcept {
  auto* gl = dynamic_cast<GlBackend*>(&backend);
  return gl ? gl->blit_to_default_framebuffer(width, height) : Status::invalid_argument;
}

}  // namespace btflod::samples
