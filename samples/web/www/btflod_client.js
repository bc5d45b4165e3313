// btflod web client: streaming .bsvtf materials from a static server with HTTP Range requests
// and drawing them with WebGL 2 through the GLSL ES 3.00 programs btflod generates.
//
// The runtime is the WebAssembly module built from samples/web/client/web_client.cpp: the
// library's Streamer (runtime/streamer.hpp — container directories, CRC checks, tile decoder,
// feedback votes, tile cache, scheduler) plus the shader generator. This file owns only I/O
// (fetch with `Range:`) and the GPU (textures, buffers, draws). Per frame:
//   1. draws every material with the bsvtf program into a float target, tone-maps to the canvas;
//   2. draws the feedback pass (R32UI, 1/4 resolution) and reads it back; once a readback has
//      arrived, its words go to the Streamer (bw_frame), which runs the decode jobs whose bytes
//      came in, plans (P = w·v, paper 000 §5; U' packets by §6 priority) and releases uploads
//      (tiles, U' packets, page-table texels: applied at once) and new reads in priority order;
//      each read becomes one Range request. Bytes are copied to the read's place in the wasm heap
//      and reported with bw_complete_read: the Streamer verifies them (size, CRC-32) before it
//      decodes, so a corrupt or truncated transfer is fetched again and never reaches the GPU.
'use strict';

const BW = { ok: 0, badArgument: 1, corrupt: 2, decodeFailed: 3, failed: 5 };
const PROGRAM = { fmf: 0, bsvtf: 1, feedback: 2, laplacian: 3, lpca: 4, pca_views: 5, spmm: 6, pca_rings: 7 };
const BINDING = {
  btflod_eigen_abrdfs: 1, btflod_angular_index: 2, btflod_angular_weight: 3, btflod_eigen_textures: 4,
  btflod_tile_cache: 5, btflod_page_table: 6, btflod_slot_map: 7, btflod_pca_l: 13, btflod_pca_r: 14,
};
// Texel formats of the tile cache (bw_set_cache_format): rgba16f (8 bytes a texel), rgba8, the
// compact one (4 bytes a texel; each slot's affine map in the slot-map texture, one RGBA32UI
// texel per slot: runtime/vt/cache_format.hpp), or bc5 (2 bytes a texel: two RGTC2 planes at
// array layers 0 and 1 with the same slot map: runtime/vt/cache_bc5.hpp).
const CACHE_FORMAT = { rgba16f: 0, rgba8: 1, bc5: 2 };
const CACHE_TEXEL_BYTES = { rgba16f: 8, rgba8: 4, bc5: 2 };
const UPLOAD_STRIDE = 11;  // UploadInfo: kind, slot, material, packet, texels, unorm8, map[4], bc5
const ORDER_BASE = 0x50000000;
const IO_ERROR = 5;  // Status::io_error, for bw_complete_read
// The ring search's uniform block (offline/packing/ring_search_block.hpp: RingSearchBlock) and the
// binding point the page gives it (ES: assigned by name, btflod_DirectionRings).
const RING_BLOCK_BYTES = 2576;
const RING_BLOCK_BINDING = 1;

// ---- small matrix helpers (column-major, like GLM) ------------------------------------------
const mat4 = {
  perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0]);
  },
  lookAt(eye, target, up) {
    const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]); return [a[0] / l, a[1] / l, a[2] / l]; };
    const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const f = norm(sub(target, eye)), s = norm(cross(f, up)), u = cross(s, f);
    return new Float32Array([s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -dot(s, eye), -dot(u, eye), dot(f, eye), 1]);
  },
  mul(a, b) {
    const o = new Float32Array(16);
    for (let c = 0; c < 4; ++c)
      for (let r = 0; r < 4; ++r) {
        let s = 0;
        for (let k = 0; k < 4; ++k) s += a[k * 4 + r] * b[c * 4 + k];
        o[c * 4 + r] = s;
      }
    return o;
  },
};

// The page's scene: material i on a 2 × 2 plane at x offset (i − (n − 1)/2) · 2.2, normal +z
// (btflod-web-tool reference renders the same planes).
function planeOrigin(i, n) { return [-1 + 2.2 * (i - 0.5 * (n - 1)), -1, 0]; }

class RangeError2 extends Error {}

/// Fetches bytes [offset, offset + size) with one Range request; resolves to
/// { bytes, total } or throws. Anything but 206 with exactly the asked range is an error.
async function fetchRange(url, offset, size, stats) {
  const end = offset + size - 1;
  const r = await fetch(url, { headers: { Range: `bytes=${offset}-${end}` }, cache: 'no-store' });
  if (r.status !== 206) throw new RangeError2(`${url}: HTTP ${r.status} for bytes=${offset}-${end}`);
  const cr = r.headers.get('Content-Range') || '';
  const m = /bytes (\d+)-(\d+)\/(\d+)/.exec(cr);
  if (!m || Number(m[1]) !== offset) throw new RangeError2(`${url}: Content-Range '${cr}' for bytes=${offset}-${end}`);
  const bytes = new Uint8Array(await r.arrayBuffer());
  stats.requests += 1;
  stats.bytes += bytes.length;
  return { bytes, total: Number(m[3]) };
}

// "Quality so far": mean SSIM (8 × 8 windows, stride 4, on luminance) of a small readback of the
// frame against the converged frame of the same view, both box-filtered to QUALITY_SIZE².
const QUALITY_SIZE = 64;
function lumaDown(img, w, h, n) {  // RGBA float32, row 0 = top → n × n luminance, row 0 = top
  const out = new Float32Array(n * n), fx = w / n, fy = h / n;
  for (let y = 0; y < n; ++y)
    for (let x = 0; x < n; ++x) {
      let s = 0, c = 0;
      for (let yy = Math.floor(y * fy); yy < Math.floor((y + 1) * fy); ++yy)
        for (let xx = Math.floor(x * fx); xx < Math.floor((x + 1) * fx); ++xx, ++c) {
          const o = (yy * w + xx) * 4;
          s += 0.2126 * img[o] + 0.7152 * img[o + 1] + 0.0722 * img[o + 2];
        }
      out[y * n + x] = c ? s / c : 0;
    }
  return out;
}
function meanSsim(a, b, n, peak) {
  const c1 = (0.01 * peak) ** 2, c2 = (0.03 * peak) ** 2;
  let sum = 0, count = 0;
  for (let y = 0; y + 8 <= n; y += 4)
    for (let x = 0; x + 8 <= n; x += 4) {
      let ma = 0, mb = 0;
      for (let j = 0; j < 8; ++j) for (let i = 0; i < 8; ++i) { ma += a[(y + j) * n + x + i]; mb += b[(y + j) * n + x + i]; }
      ma /= 64; mb /= 64;
      let va = 0, vb = 0, cov = 0;
      for (let j = 0; j < 8; ++j)
        for (let i = 0; i < 8; ++i) {
          const da = a[(y + j) * n + x + i] - ma, db = b[(y + j) * n + x + i] - mb;
          va += da * da; vb += db * db; cov += da * db;
        }
      va /= 63; vb /= 63; cov /= 63;
      sum += ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
      count += 1;
    }
  return count ? sum / count : 0;
}

export class BtflodClient {
  /// canvas: a WebGL 2 canvas; module: the instantiated wasm module; options: see defaults.
  constructor(canvas, module, options = {}) {
    this.canvas = canvas;
    this.M = module;
    this.opt = Object.assign({
      slotsX: 24, slotsY: 24, uploadsPerFrame: 16, requestsInFlight: 48, fetchConcurrency: 6,
      angularResolution: 32, feedbackShift: 2, streamU: true, maxRetries: 4, readbackBuffers: 3,
      readbackMaxFrames: 3, qualityEvery: 2, cacheFormat: 'rgba16f', noRgtc: false,
    }, options);
    if (!(this.opt.cacheFormat in CACHE_FORMAT))
      throw new Error(`cacheFormat ${this.opt.cacheFormat}: rgba16f, rgba8 or bc5`);
    this.gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true, premultipliedAlpha: false });
    if (!this.gl) throw new Error('WebGL 2 is not available');
    if (!this.gl.getExtension('EXT_color_buffer_float')) throw new Error('EXT_color_buffer_float is not available');
    this.materials = [];
    this.stats = { requests: 0, bytes: 0, payloadBytes: 0, corrupt: 0, retries: 0, failures: 0, uploads: 0, frames: 0,
      directoryBytes: 0, tileUploads: 0, slotMapUploads: 0, cacheBytes: 0, tileUploadBytes: 0,
      cacheFormat: this.opt.cacheFormat, cacheFormatFallback: '' };
    // WebGL 2 samples BC5 (RGTC2) only through EXT_texture_compression_rgtc; without it (or with
    // noRgtc, which pretends it is missing) a bc5 request keeps the rgba8 cache, which has the same
    // slot maps at twice the bytes, and says so.
    if (this.opt.cacheFormat === 'bc5') {
      this.rgtc = this.opt.noRgtc ? null : this.gl.getExtension('EXT_texture_compression_rgtc');
      if (!this.rgtc) {
        this.stats.cacheFormat = 'rgba8';
        this.stats.cacheFormatFallback = `bc5 → rgba8: EXT_texture_compression_rgtc is ${
          this.opt.noRgtc ? 'switched off (noRgtc)' : 'not offered'}`;
        console.log(`btflod: cache format ${this.stats.cacheFormatFallback}`);
      }
    }
    this.cacheFormat = this.stats.cacheFormat;  // the one in use
    this.timeline = [];     // { t, bytes, quality }
    this.queue = [];        // requests waiting for a fetch slot
    this.active = 0;
    this.view = { yaw: -1.2, pitch: 0.75, distance: 4.2, target: [0, 0, 0], fov: 45, light: [-0.5, 0.4, 0.8],
      lightColor: [1.6, 1.4, 1.2], bias: 0, eye: null };
    this.frameMs = 0;
    // Client-side LRU of verified payloads (paper 000 §6: keep received tiles in RAM), so a tile
    // the scheduler evicts and wants back later is not fetched again. Bounded by bytes; only
    // bytes whose CRC-32 matches their directory entry (bw_payload_ok) are kept.
    this.payloads = new Map();
    this.payloadBytes = 0;
    this.payloadBudget = 64 << 20;
    this.faults = null;     // test hook: function(info, attempt, url) → url to fetch instead, or null
    this.startTime = performance.now();
  }

  heapCopy(bytes) {
    const p = this.M._malloc(bytes.length);
    this.M.HEAPU8.set(bytes, p);
    return p;
  }
  error() { return this.M.UTF8ToString(this.M._bw_last_error()); }

  /// Loads the container directories (header, then directory: two Range requests each) and
  /// creates the runtime, the GPU resources and the programs. urls: one .bsvtf per material.
  async open(urls) {
    const M = this.M;
    M._bw_set_angular_resolution(this.opt.angularResolution);
    for (const url of urls) {
      const head = await fetchRange(url, 0, 128, this.stats);
      const hp = this.heapCopy(head.bytes);
      const dirSize = M._bw_directory_size(hp, 128, head.total);
      M._free(hp);
      if (!dirSize) throw new Error(`${url}: ${this.error()}`);
      const dir = await fetchRange(url, 0, dirSize, this.stats);
      this.stats.directoryBytes += 128 + dir.bytes.length;
      const dp = this.heapCopy(dir.bytes);
      const index = M._bw_add_material(dp, dir.bytes.length, head.total);
      M._free(dp);
      if (index < 0 || index > 1000) throw new Error(`${url}: ${this.error()}`);
      this.materials.push({ url, index, fileSize: head.total });
    }
    const o = this.opt;
    if (o.decodedTiles) M._bw_set_decoded_capacity(o.decodedTiles);  // decoded ancestors kept
    if (M._bw_set_cache_format(CACHE_FORMAT[this.cacheFormat]) !== 0) throw new Error(this.error());
    if (M._bw_start(o.slotsX, o.slotsY, 0, o.uploadsPerFrame, o.requestsInFlight, o.streamU ? 1 : 0) !== 0)
      throw new Error(this.error());
    this.initGpu();
    // Pinned roots first (one per virtual texture), before any feedback: the Streamer asks for
    // them on its first frames.
    const deadline = performance.now() + 60000;
    while (!M._bw_ready()) {
      if (performance.now() > deadline) throw new Error('root tiles did not arrive within 60 s');
      this.streamFrame(0, 0);
      await new Promise((r) => setTimeout(r, 1));
    }
  }

  // One Streamer frame with `count` feedback words at heap address `words`: decode jobs whose
  // bytes arrived run, the uploads it releases are applied (their texels are valid until the
  // next frame), and its new reads join the fetch queue.
  streamFrame(words, count) {
    const M = this.M;
    const n = M._bw_frame(words, count);
    if (n < 0) throw new Error(this.error());
    const reads = new Uint32Array(M.HEAPU8.buffer, M._bw_reads(), n * 7).slice();
    for (let i = 0; i < n; ++i) {
      const b = i * 7;
      this.queue.push({ ticket: [reads[b], reads[b + 1]], material: reads[b + 2],
        offset: reads[b + 3] + reads[b + 4] * 2 ** 32, size: reads[b + 5], destination: reads[b + 6] });
    }
    this.applyUploads();
    this.faultsHeap = this.faultsHeap || M._malloc(16);  // once: nothing allocates per frame
    M._bw_faults(this.faultsHeap);
    const [refused, failed] = new Float64Array(M.HEAPU8.buffer, this.faultsHeap, 2);
    this.stats.corrupt = refused;
    this.stats.decodeFailures = failed;
    this.pump();
  }

  orderInfo(arr, i) {
    const b = i * 8;
    return { id: arr[b], material: arr[b + 1], kind: arr[b + 2], key: arr[b + 3] + arr[b + 4] * 2 ** 32,
      offset: arr[b + 5] + arr[b + 6] * 2 ** 32, size: arr[b + 7] };
  }

  /// One Range request of `info` (offset, size) with the client's retry policy: a failed
  /// transfer (HTTP error, dropped connection, wrong Content-Range) is retried until
  /// opt.maxRetries attempts in all, counting from `attempt`. The faults hook may name another
  /// URL per attempt. Resolves to { bytes, attempt } or null after the last failed attempt.
  async fetchWithRetries(info, url, attempt = 0) {
    for (; ; ++attempt) {
      try {
        // Test hook: another URL for this attempt (a copy with corrupted payloads, or a URL the
        // server answers by closing the connection) — real transfers, no bytes altered here.
        const u = this.faults ? this.faults(info, attempt, url) || url : url;
        const { bytes } = await fetchRange(u, info.offset, info.size, this.stats);
        this.stats.payloadBytes += bytes.length;
        return { bytes, attempt };
      } catch (e) {
        this.stats.retries += 1;
        if (attempt + 1 >= this.opt.maxRetries) {
          this.stats.failures += 1;
          return null;
        }
      }
    }
  }

  // One read of the Streamer: from the payload LRU or one fetch with retries; the bytes go to
  // the read's destination in the wasm heap and the read is reported. The Streamer verifies them
  // (a corrupt payload comes back as a refused tile and a new read); a transfer that failed
  // opt.maxRetries times is reported as an I/O error (the tile is planned again).
  async serveRead(read) {
    const M = this.M;
    const key = `${read.material}:${read.offset}`;
    const complete = (bytes) => {
      if (bytes) M.HEAPU8.set(bytes, read.destination);  // M.HEAPU8 now: the heap may have grown
      M._bw_complete_read(read.ticket[0], read.ticket[1], bytes ? 0 : IO_ERROR);
    };
    const cached = this.payloads.get(key);
    if (cached && cached.length === read.size) {
      this.payloads.delete(key);  // most recently used last
      this.payloads.set(key, cached);
      this.stats.cacheHits = (this.stats.cacheHits || 0) + 1;
      complete(cached);
      return;
    }
    const got = await this.fetchWithRetries(read, this.materials[read.material].url);
    if (!got || got.bytes.length !== read.size) {
      if (got) this.stats.failures += 1;
      complete(null);
      return;
    }
    complete(got.bytes);
    if (!this.payloads.has(key) && M._bw_payload_ok(read.material, read.offset, read.destination, read.size)) {
      this.payloads.set(key, got.bytes);
      this.payloadBytes += got.bytes.length;
      for (const [k, v] of this.payloads) {
        if (this.payloadBytes <= this.payloadBudget) break;
        this.payloads.delete(k);
        this.payloadBytes -= v.length;
      }
    }
  }

  pump() {
    while (this.active < this.opt.fetchConcurrency && this.queue.length) {
      const info = this.queue.shift();
      this.active += 1;
      this.serveRead(info).finally(() => { this.active -= 1; this.pump(); });
    }
  }

  // ---- GPU ----------------------------------------------------------------------------------
  compile(type, src) {
    const gl = this.gl, s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
    return s;
  }
  link(vs, fs) {
    const gl = this.gl, p = gl.createProgram();
    gl.attachShader(p, this.compile(gl.VERTEX_SHADER, vs));
    gl.attachShader(p, this.compile(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(`link: ${gl.getProgramInfoLog(p)}`);
    const block = gl.getUniformBlockIndex(p, 'BtflodParams');
    if (block !== gl.INVALID_INDEX) gl.uniformBlockBinding(p, block, 0);
    gl.useProgram(p);
    for (const [name, unit] of Object.entries(BINDING)) {
      const loc = gl.getUniformLocation(p, name);
      if (loc) gl.uniform1i(loc, unit);
    }
    return p;
  }
  generated(program, material) {
    const M = this.M;
    const vs = M._bw_program_source(program, 0, material);
    if (!vs) throw new Error(this.error());
    const v = M.UTF8ToString(vs);
    const f = M.UTF8ToString(M._bw_program_source(program, 1, material));
    return this.link(v, f);
  }

  texArray(internal, w, h, layers, filter, levels = 1) {
    const gl = this.gl, t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, t);
    gl.texStorage3D(gl.TEXTURE_2D_ARRAY, levels, internal, w, h, layers);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MIN_FILTER, filter);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MAG_FILTER, filter);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    return t;
  }

  initGpu() {
    const gl = this.gl, M = this.M;
    const info = new Uint32Array(16);
    const ip = M._malloc(64);
    this.info = [];
    for (const m of this.materials) {
      M._bw_material_info(m.index, ip);
      info.set(new Uint32Array(M.HEAPU8.buffer, ip, 16));
      const [width, height, levels, C, lights, views, firstLayer, tile, border, finest, packets, , pageSide, sx, sy, res] = info;
      Object.assign(m, { width, height, levels, C, lights, views, firstLayer, tile, border, finest, packets, pageSide, res });
      this.slots = [sx, sy];
      this.stored = tile + 2 * border;
      this.pageSide = pageSide;
    }
    M._free(ip);
    const S = this.stored;
    this.compactCache = this.cacheFormat !== 'rgba16f';  // rgba8 or bc5: a slot map per slot
    this.bc5Cache = this.cacheFormat === 'bc5';
    // GPU memory of the cache: its texels (8, 4 or 2 bytes each) and, compact, the slot-map texels.
    this.stats.cacheBytes = this.slots[0] * S * this.slots[1] * S * CACHE_TEXEL_BYTES[this.cacheFormat] +
      (this.compactCache ? this.slots[0] * this.slots[1] * 16 : 0);
    // bc5: plane p (components 2p, 2p + 1) at array layer p; every slot origin is a multiple of
    // S = T + 2B, a multiple of the 4 × 4 block (checked here: compressed sub-images need it).
    if (this.bc5Cache && S % 4 !== 0) throw new Error(`bc5 cache: stored tile side ${S} is not a multiple of 4`);
    this.cacheTex = this.texArray(
      this.bc5Cache ? this.rgtc.COMPRESSED_RED_GREEN_RGTC2_EXT : this.compactCache ? gl.RGBA8 : gl.RGBA16F,
      this.slots[0] * S, this.slots[1] * S, this.bc5Cache ? 2 : 1, gl.LINEAR);
    if (this.compactCache) {  // one RGBA32UI texel per slot (cache_slot_map_texel: one layer)
      this.slotMapTex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, this.slotMapTex);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32UI, this.slots[0], this.slots[1]);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    }
    const layers = M._bw_texture_count();
    const pageLevels = Math.log2(this.pageSide) + 1;
    this.pageTex = this.texArray(gl.R32UI, this.pageSide, this.pageSide, layers, gl.NEAREST, pageLevels);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MIN_FILTER, gl.NEAREST_MIPMAP_NEAREST);
    for (let l = 0; l < pageLevels; ++l) {
      const side = this.pageSide >> l;
      gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, l, 0, 0, 0, side, side, layers, gl.RED_INTEGER, gl.UNSIGNED_INT,
        new Uint32Array(side * side * layers));
    }
    const n = this.materials.length;
    for (const m of this.materials) {
      m.uTex = this.texArray(gl.RGBA32F, m.lights, m.views, m.C, gl.NEAREST);
      m.angIndex = this.texArray(gl.RGBA32UI, m.res, m.res, 2, gl.NEAREST);
      gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, 0, m.res, m.res, 2, gl.RGBA_INTEGER, gl.UNSIGNED_INT,
        new Uint32Array(M.HEAPU8.buffer, M._bw_angular_index(m.index), m.res * m.res * 8));
      m.angWeight = this.texArray(gl.RGBA32F, m.res, m.res, 2, gl.NEAREST);
      gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, 0, m.res, m.res, 2, gl.RGBA, gl.FLOAT,
        new Float32Array(M.HEAPU8.buffer, M._bw_angular_weight(m.index), m.res * m.res * 8));
      m.program = this.generated(PROGRAM.bsvtf, m.index);
      m.feedbackProgram = this.generated(PROGRAM.feedback, m.index);
      m.vao = this.planeVao(planeOrigin(m.index, n));
    }
    this.initFrameResources();
    this.resize(this.canvas.width, this.canvas.height);
  }

  // Shared by every client: the BtflodParams uniform buffer (binding 0, ShaderParams' 224 bytes)
  // and the display program (float colour target → sRGB canvas).
  initFrameResources() {
    const gl = this.gl;
    this.ubo = gl.createBuffer();
    gl.bindBuffer(gl.UNIFORM_BUFFER, this.ubo);
    gl.bufferData(gl.UNIFORM_BUFFER, 224, gl.DYNAMIC_DRAW);
    gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, this.ubo);
    this.params = new ArrayBuffer(224);
    this.paramsF = new Float32Array(this.params);
    this.paramsU = new Uint32Array(this.params);
    this.display = this.link(
      '#version 300 es\nout vec2 uv;\nvoid main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n' +
      ' uv = p; gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }\n',
      '#version 300 es\nprecision highp float;\nin vec2 uv;\nuniform sampler2D img;\nout vec4 color;\n' +
      'void main() { vec3 c = max(texture(img, uv).rgb, 0.0);\n' +
      ' c = mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));\n' +
      ' color = vec4(clamp(c, 0.0, 1.0), 1.0); }\n');
  }

  planeVao(o) {
    const gl = this.gl;
    const v = [];
    for (const [a, b] of [[0, 0], [1, 0], [1, 1], [0, 1]])
      v.push(o[0] + 2 * a, o[1] + 2 * b, o[2], 0, 0, 1, 1, 0, 0, 1, a, b);
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const vb = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, vb);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(v), gl.STATIC_DRAW);
    const sizes = [3, 3, 4, 2];
    let off = 0;
    sizes.forEach((s, loc) => {
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, s, gl.FLOAT, false, 48, off);
      off += s * 4;
    });
    const ib = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, new Uint16Array([0, 1, 2, 0, 2, 3]), gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return vao;
  }

  resize(w, h) {
    const gl = this.gl;
    this.width = w;
    this.height = h;
    const target = (internal, tw, th) => {
      const t = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.texStorage2D(gl.TEXTURE_2D, 1, internal, tw, th);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      return t;
    };
    const fbo = (tex, tw, th) => {
      const f = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, f);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
      const d = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, d);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, tw, th);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, d);
      if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) throw new Error('framebuffer incomplete');
      return f;
    };
    this.colorTex = target(gl.RGBA32F, w, h);
    this.colorFbo = fbo(this.colorTex, w, h);
    const s = this.opt.feedbackShift;
    this.fbW = Math.max(1, w >> s);
    this.fbH = Math.max(1, h >> s);
    this.feedbackTex = target(gl.R32UI, this.fbW, this.fbH);
    this.feedbackFbo = fbo(this.feedbackTex, this.fbW, this.fbH);
    this.feedbackWords = new Uint32Array(this.fbW * this.fbH * 4);
    this.feedbackHeap = this.M._malloc(this.fbW * this.fbH * 4);
    for (const r of this.readbacks || []) {
      if (r.fence) gl.deleteSync(r.fence);
      gl.deleteBuffer(r.buffer);
    }
    this.pending = [];
    this.readbacks = Array.from({ length: this.opt.readbackBuffers }, () => {
      const buffer = gl.createBuffer();
      gl.bindBuffer(gl.PIXEL_PACK_BUFFER, buffer);
      gl.bufferData(gl.PIXEL_PACK_BUFFER, this.fbW * this.fbH * 16, gl.STREAM_READ);
      return { buffer, fence: null };
    });
    gl.bindBuffer(gl.PIXEL_PACK_BUFFER, null);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  }

  eye() {
    const v = this.view;
    if (v.eye) return v.eye;
    const cp = Math.cos(v.pitch);
    return [v.target[0] + v.distance * cp * Math.cos(v.yaw), v.target[1] + v.distance * cp * Math.sin(v.yaw),
      v.target[2] + v.distance * Math.sin(v.pitch)];
  }

  writeParams(m, lodY) {
    const v = this.view, F = this.paramsF, U = this.paramsU;
    const eye = this.eye();
    const proj = mat4.perspective(v.fov * Math.PI / 180, this.width / this.height, 0.05, 50);
    F.set(mat4.mul(proj, mat4.lookAt(eye, v.target, [0, 0, 1])), 0);
    F.set([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], 16);
    F.set([eye[0], eye[1], eye[2], 1], 32);
    const l = v.light, ll = Math.hypot(l[0], l[1], l[2]);
    F.set([l[0] / ll, l[1] / ll, l[2] / ll, 0], 36);
    F.set([v.lightColor[0], v.lightColor[1], v.lightColor[2], 1], 40);
    F.set([v.bias, lodY, 1, 0], 44);
    F.set([m.width, m.height, m.finest, 0], 48);
    U.set([m.firstLayer, m.index, 0, 0], 52);
    const gl = this.gl;
    gl.bindBuffer(gl.UNIFORM_BUFFER, this.ubo);
    gl.bufferSubData(gl.UNIFORM_BUFFER, 0, this.params);
  }

  bindTextures(m) {
    const gl = this.gl;
    const bind = (unit, tex) => { gl.activeTexture(gl.TEXTURE0 + unit); gl.bindTexture(gl.TEXTURE_2D_ARRAY, tex); };
    bind(1, m.uTex);
    bind(2, m.angIndex);
    bind(3, m.angWeight);
    bind(5, this.cacheTex);
    bind(6, this.pageTex);
    if (this.compactCache) {
      gl.activeTexture(gl.TEXTURE0 + BINDING.btflod_slot_map);
      gl.bindTexture(gl.TEXTURE_2D, this.slotMapTex);
    }
  }

  // Uploads released tiles and packets and the page-table texels they changed.
  applyUploads() {
    const gl = this.gl, M = this.M;
    const n = M._bw_apply_uploads();
    if (n < 0) throw new Error(this.error());
    const S = this.stored;
    const ups = new Uint32Array(M.HEAPU8.buffer, M._bw_uploads(), n * UPLOAD_STRIDE).slice();
    for (let i = 0; i < n; ++i) {
      const u = i * UPLOAD_STRIDE;
      const [kind, slot, material] = [ups[u], ups[u + 1], ups[u + 2]];
      if (kind === 0) {
        this.stats.tileUploads += 1;
        const sx = slot % this.slots[0], sy = Math.floor(slot / this.slots[0]);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, this.cacheTex);
        if (this.compactCache) {
          if (this.bc5Cache) {  // two planes of S² bytes (16 bytes per 4 × 4 texels), layers 0 and 1
            for (let plane = 0; plane < 2; ++plane)
              gl.compressedTexSubImage3D(gl.TEXTURE_2D_ARRAY, 0, sx * S, sy * S, plane, S, S, 1,
                this.rgtc.COMPRESSED_RED_GREEN_RGTC2_EXT, new Uint8Array(M.HEAPU8.buffer, ups[u + 10] + plane * S * S, S * S));
            this.stats.tileUploadBytes += 2 * S * S;
          } else {
            const bytes = new Uint8Array(M.HEAPU8.buffer, ups[u + 5], S * S * 4);
            gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, sx * S, sy * S, 0, S, S, 1, gl.RGBA, gl.UNSIGNED_BYTE, bytes);
            this.stats.tileUploadBytes += 4 * S * S;
          }
          gl.bindTexture(gl.TEXTURE_2D, this.slotMapTex);
          gl.texSubImage2D(gl.TEXTURE_2D, 0, sx, sy, 1, 1, gl.RGBA_INTEGER, gl.UNSIGNED_INT, ups.subarray(u + 6, u + 10));
          this.stats.slotMapUploads += 1;
        } else {
          const texels = new Uint16Array(M.HEAPU8.buffer, ups[u + 4], S * S * 4);
          gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, sx * S, sy * S, 0, S, S, 1, gl.RGBA, gl.HALF_FLOAT, texels);
          this.stats.tileUploadBytes += 8 * S * S;
        }
      } else {
        const m = this.materials[material];
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, m.uTex);
        gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, 0, m.lights, m.views, m.C, gl.RGBA, gl.FLOAT,
          new Float32Array(M.HEAPU8.buffer, M._bw_u_rgba(m.index), m.lights * m.views * m.C * 4));
      }
      this.stats.uploads += 1;
    }
    const w = M._bw_page_write_count();
    if (w > 0) {
      const pw = new Uint32Array(M.HEAPU8.buffer, M._bw_page_writes(), w * 5).slice();
      gl.bindTexture(gl.TEXTURE_2D_ARRAY, this.pageTex);
      const one = new Uint32Array(1);
      for (let i = 0; i < w; ++i) {
        one[0] = pw[i * 5 + 4];
        gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, pw[i * 5 + 1], pw[i * 5 + 2], pw[i * 5 + 3], pw[i * 5], 1, 1, 1,
          gl.RED_INTEGER, gl.UNSIGNED_INT, one);
      }
    }
    M._bw_uploads_done();  // uploads and page writes applied
    return n;
  }

  // Binds framebuffer `fbo` with a w × h viewport and depth testing, clears its colour with
  // `clearColor()` and its depth.
  beginPass(fbo, w, h, clearColor) {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.viewport(0, 0, w, h);
    gl.enable(gl.DEPTH_TEST);
    clearColor();
    gl.clear(gl.DEPTH_BUFFER_BIT);
  }

  drawColor() {
    const gl = this.gl;
    this.beginPass(this.colorFbo, this.width, this.height, () => gl.clearBufferfv(gl.COLOR, 0, [0, 0, 0, 0]));
    for (const m of this.materials) {
      gl.useProgram(m.program);
      this.writeParams(m, 0);
      this.bindTextures(m);
      gl.bindVertexArray(m.vao);
      gl.drawElements(gl.TRIANGLES, 6, gl.UNSIGNED_SHORT, 0);
    }
    gl.bindVertexArray(null);
  }

  present() {
    const gl = this.gl;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.disable(gl.DEPTH_TEST);
    gl.useProgram(this.display);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.colorTex);
    gl.uniform1i(gl.getUniformLocation(this.display, 'img'), 0);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  // Feedback pass (paper 000 eq. 1–2) at 1/2^shift resolution, read back without a stall: the
  // words go into a PIXEL_PACK_BUFFER (one of opt.readbackBuffers) behind a fence, and a later
  // frame whose fence has signalled (clientWaitSync with timeout 0: polling) hands them to the
  // scheduler (votes, plan, requests). When every buffer is still in flight the pass is skipped;
  // a readback older than opt.readbackMaxFrames frames is taken anyway (the browser may then
  // wait for the GPU: counted in stats.feedbackForced), so the feedback latency stays bounded
  // where the browser signals fences late (headless pages update them once per compositor frame).
  feedback() {
    const gl = this.gl;
    const slot = this.readbacks.find((r) => !r.fence);
    if (slot) {
      this.beginPass(this.feedbackFbo, this.fbW, this.fbH, () => gl.clearBufferuiv(gl.COLOR, 0, [0xffffffff, 0, 0, 0]));
      for (const m of this.materials) {
        gl.useProgram(m.feedbackProgram);
        this.writeParams(m, this.opt.feedbackShift);
        gl.activeTexture(gl.TEXTURE6);
        gl.bindTexture(gl.TEXTURE_2D_ARRAY, this.pageTex);
        gl.bindVertexArray(m.vao);
        gl.drawElements(gl.TRIANGLES, 6, gl.UNSIGNED_SHORT, 0);
      }
      gl.bindVertexArray(null);
      gl.bindBuffer(gl.PIXEL_PACK_BUFFER, slot.buffer);
      gl.readPixels(0, 0, this.fbW, this.fbH, gl.RGBA_INTEGER, gl.UNSIGNED_INT, 0);
      gl.bindBuffer(gl.PIXEL_PACK_BUFFER, null);
      slot.fence = gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
      slot.frame = this.stats.frames;
      this.pending.push(slot);
      gl.flush();
    } else {
      this.stats.feedbackSkipped = (this.stats.feedbackSkipped || 0) + 1;
    }
    while (this.pending.length && this.pollFeedback()) {}
  }

  // The oldest pending readback, if its fence has signalled: words → votes → plan → requests.
  // Returns false when it is still in flight.
  pollFeedback() {
    const gl = this.gl, M = this.M, slot = this.pending[0];
    const status = gl.clientWaitSync(slot.fence, 0, 0);
    if (status === gl.TIMEOUT_EXPIRED) {
      if (this.stats.frames - slot.frame < this.opt.readbackMaxFrames) {
        this.stats.feedbackWaits = (this.stats.feedbackWaits || 0) + 1;
        return false;
      }
      this.stats.feedbackForced = (this.stats.feedbackForced || 0) + 1;
    }
    gl.deleteSync(slot.fence);
    slot.fence = null;
    this.pending.shift();
    gl.bindBuffer(gl.PIXEL_PACK_BUFFER, slot.buffer);
    gl.getBufferSubData(gl.PIXEL_PACK_BUFFER, 0, this.feedbackWords);
    gl.bindBuffer(gl.PIXEL_PACK_BUFFER, null);
    this.stats.feedbackReadbacks = (this.stats.feedbackReadbacks || 0) + 1;
    const n = this.fbW * this.fbH;
    const words = new Uint32Array(M.HEAPU8.buffer, this.feedbackHeap, n);
    this.visible = new Set();
    for (let i = 0; i < n; ++i) {
      const w = this.feedbackWords[i * 4];
      words[i] = w;
      if (w !== 0xffffffff) this.visible.add(w >>> 22);  // material field of the feedback word
    }
    this.streamFrame(this.feedbackHeap, n);
    return true;
  }

  /// Switches to paper 004's fixed order for comparison (§5: component by component — U'
  /// packet g, then every tile of virtual texture g coarse to fine — no feedback, no scheduler).
  startComponentOrder() {
    const M = this.M;
    const n = M._bw_component_order();
    if (n < 0) throw new Error(this.error());
    const list = new Uint32Array(M.HEAPU8.buffer, M._bw_order(), n * 8).slice();
    this.fixedOrder = true;
    this.orderLeft = n;
    for (let i = 0; i < n; ++i) this.queue.push(this.orderInfo(list, i));
    // Deliveries must reach the wasm side in order (a tile needs its parent): one fetch at a time
    // ahead of delivery would be slow, so fetch concurrently and deliver in sequence.
    this.orderBuffer = new Map();
    this.orderNext = 0;
    this.orderList = this.queue.splice(0);
    this.pumpOrder();
  }

  pumpOrder() {
    while (this.active < this.opt.fetchConcurrency && this.orderList.length) {
      const info = this.orderList.shift();
      const seq = info.id - ORDER_BASE;
      this.active += 1;
      fetchRange(this.materials[info.material].url, info.offset, info.size, this.stats).then(({ bytes }) => {
        this.orderBuffer.set(seq, { info, bytes });
        while (this.orderBuffer.has(this.orderNext)) {
          const item = this.orderBuffer.get(this.orderNext);
          this.orderBuffer.delete(this.orderNext);
          const p = this.heapCopy(item.bytes);
          const code = this.M._bw_deliver_ordered(item.info.id, p, item.bytes.length);
          this.M._free(p);
          if (code !== BW.ok) this.stats.failures += 1;
          this.orderNext += 1;
          this.orderLeft -= 1;
          this.applyUploads();  // staged texels stay valid only until the next delivery's upload
        }
      }).finally(() => { this.active -= 1; this.pumpOrder(); });
    }
  }

  /// One frame: uploads, colour pass, present, feedback + planning. Returns the frame's ms.
  frame() {
    const t0 = performance.now();
    this.applyUploads();
    this.drawColor();
    this.present();
    if (!this.fixedOrder) this.feedback();
    this.updateQuality();
    this.stats.frames += 1;
    const t = performance.now() - this.startTime;
    this.timeline.push({ t, bytes: this.stats.bytes, quality: this.quality() });
    this.frameMs = performance.now() - t0;
    return this.frameMs;
  }

  /// The runtime's decoded-ancestor cache: { capacity (tiles), skipped (tile levels a decode
  /// started below because an ancestor was kept), bytesRead (payload bytes), bytes (cache size),
  /// pendingWrites (page-table texels waiting) }.
  decodedStats() {
    const p = this.M._malloc(40);
    this.M._bw_decoded_stats(p);
    const [capacity, skipped, bytesRead, bytes, pendingWrites] = new Float64Array(this.M.HEAPU8.buffer, p, 5);
    this.M._free(p);
    return { capacity, skipped, bytesRead, bytes, pendingWrites };
  }

  /// The "quality so far" the page shows: the SSIM estimate against the converged frame when
  /// setQualityReference() gave one, else Σ w of delivered tiles / Σ w of all tiles over the
  /// materials (paper 000 eq. 8: w is the error a tile removes).
  quality() {
    if (this.qualityRef) return this.qualitySsim;
    let q = 0;
    for (const m of this.materials) q += this.M._bw_converged_fraction(m.index);
    return q / this.materials.length;
  }

  /// True when the Streamer has seen the view (a feedback readback reached update()), nothing is
  /// in flight or queued, the view misses no tile it voted for, and the scheduler's overload LOD
  /// bias is back at 0 (votes at full detail). Before the first readback there are no votes, so
  /// nothing counts as missing: where fences signal late (headless SwiftShader under load) the
  /// first frames would otherwise look converged with the root tiles alone.
  converged() {
    if (this.fixedOrder) return this.orderLeft === 0;
    if (!this.stats.feedbackReadbacks) return false;
    let packets = true;
    const ip = this.M._malloc(64);
    for (const m of this.materials) {
      if (this.visible && !this.visible.has(m.index)) continue;  // out of view: its U' is not needed
      this.M._bw_material_info(m.index, ip);
      const info = new Uint32Array(this.M.HEAPU8.buffer, ip, 16);
      if (info[11] < info[10]) packets = false;
    }
    this.M._free(ip);
    return packets && this.queue.length === 0 && this.active === 0 && this.M._bw_in_flight() === 0 &&
      this.M._bw_visible_missing() === 0 && this.M._bw_lod_bias() === 0;
  }

  /// The last colour frame as linear RGBA float32, row 0 = top (the CPU reference's order).
  readColor() {
    const gl = this.gl, w = this.width, h = this.height;
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.colorFbo);
    const px = new Float32Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, px);
    const out = new Float32Array(w * h * 4);
    for (let y = 0; y < h; ++y) out.set(px.subarray((h - 1 - y) * w * 4, (h - y) * w * 4), y * w * 4);
    return out;
  }

  /// Sets the converged frame of the current view (linear RGBA float32 of the canvas size, row
  /// 0 = top: e.g. the CPU reference of that view). quality() is then the SSIM of a
  /// QUALITY_SIZE² readback of each opt.qualityEvery-th frame against it; null goes back to the
  /// Σw estimate.
  setQualityReference(img) {
    this.qualityRef = img ? lumaDown(img, this.width, this.height, QUALITY_SIZE) : null;
    this.qualityPeak = this.qualityRef ? Math.max(1e-6, ...this.qualityRef) : 1;
    this.qualitySsim = 0;
  }

  // Box-filters the colour target to QUALITY_SIZE² luminance on the GPU, reads those 64 × 64
  // texels back and updates the SSIM estimate.
  updateQuality() {
    if (!this.qualityRef || this.stats.frames % this.opt.qualityEvery) return;
    const gl = this.gl, n = QUALITY_SIZE;
    if (!this.qualityProgram) {
      this.qualityProgram = this.link(
        '#version 300 es\nvoid main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n' +
        ' gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }\n',
        '#version 300 es\nprecision highp float;\nuniform sampler2D img;\nuniform ivec2 box;\nout vec4 color;\n' +
        'void main() { ivec2 p = ivec2(gl_FragCoord.xy) * box; vec3 s = vec3(0.0);\n' +
        ' for (int y = 0; y < box.y; ++y) for (int x = 0; x < box.x; ++x) s += texelFetch(img, p + ivec2(x, y), 0).rgb;\n' +
        ' color = vec4(dot(s / float(box.x * box.y), vec3(0.2126, 0.7152, 0.0722)), 0.0, 0.0, 1.0); }\n');
      this.qualityTex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, this.qualityTex);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, n, n);
      this.qualityFbo = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, this.qualityFbo);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, this.qualityTex, 0);
      this.qualityPixels = new Float32Array(n * n * 4);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, this.qualityFbo);
    gl.viewport(0, 0, n, n);
    gl.disable(gl.DEPTH_TEST);
    gl.useProgram(this.qualityProgram);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, this.colorTex);
    gl.uniform1i(gl.getUniformLocation(this.qualityProgram, 'img'), 0);
    gl.uniform2i(gl.getUniformLocation(this.qualityProgram, 'box'), Math.floor(this.width / n), Math.floor(this.height / n));
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.readPixels(0, 0, n, n, gl.RGBA, gl.FLOAT, this.qualityPixels);
    const luma = new Float32Array(n * n);
    for (let y = 0; y < n; ++y) for (let x = 0; x < n; ++x) luma[y * n + x] = this.qualityPixels[((n - 1 - y) * n + x) * 4];
    this.qualitySsim = meanSsim(luma, this.qualityRef, n, this.qualityPeak);
  }

  /// Mean ms of `frames` colour passes, each waited for (readPixels of one texel).
  benchmark(frames) {
    const gl = this.gl, one = new Float32Array(4);
    this.drawColor();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.FLOAT, one);
    const t0 = performance.now();
    for (let i = 0; i < frames; ++i) {
      this.drawColor();
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.FLOAT, one);
    }
    return (performance.now() - t0) / frames;
  }
}

/// PCA-k as paper 004 draws it (PCA over groups of k neighbouring views, L = [m | UΣ],
/// R = [1; Vᵀ]; the light/view lookup by the ring search over a uniform block, §4.4) with
/// btflod's generated pca_rings program, streamed component by component (§5): the .pcak file
/// (btflod-web-tool pcak) is fetched from the same static server with one Range request per
/// chunk — header, chunk table, then chunk 0 (ring block and mean plane) and components 1..C in
/// order. Every chunk is checked against its CRC-32 before it touches a texture; a corrupt or
/// dropped transfer is requested again. Missing components are zeros in L and R, so the frame
/// is the rank-c reconstruction while c components have arrived. One 2 × 2 plane at the origin.
export class PcakClient extends BtflodClient {
  async open(url) {
    const head = await fetchRange(url, 0, 64, this.stats);
    const h = new Uint32Array(head.bytes.buffer, head.bytes.byteOffset, 16).slice();
    if (h[0] !== 0x4b414350 || h[1] !== 2) throw new Error(`${url}: not a version 2 .pcak file`);
    const [C, k, lights, views, W, H, groups, chunkCount, blockBytes] = Array.from(h.subarray(2, 11));
    if (chunkCount !== C + 1 || C < 1 || C > 64 || !W || !H || !groups || blockBytes !== RING_BLOCK_BYTES)
      throw new Error(`${url}: inconsistent .pcak header`);
    this.url = url;
    const tableBytes = await this.fetchVerified({ kind: 2, offset: 64, size: 16 * chunkCount, chunk: -1 }, h[14]);
    const table = new Uint32Array(tableBytes.buffer, tableBytes.byteOffset, 4 * chunkCount).slice();
    const plane = groups * W * H, rows = lights * views;
    this.chunks = [];
    let end = 64 + 16 * chunkCount;
    for (let c = 0; c < chunkCount; ++c) {
      const [offset, size, crc] = [table[4 * c], table[4 * c + 1], table[4 * c + 2]];
      const want = c === 0 ? blockBytes + 4 * plane : 4 * (plane + 4 * rows);
      if (offset !== end || size !== want) throw new Error(`${url}: chunk ${c} at ${offset}, ${size} bytes`);
      end += size;
      this.chunks.push({ kind: 2, chunk: c, offset, size, crc });
    }
    if (end !== head.total) throw new Error(`${url}: ${head.total} bytes, the chunk table says ${end}`);
    const gl = this.gl;
    const layers = Math.floor((C + 4) / 4);  // L layers per group: components 0..C
    const m = { index: 0, C, k, lights, views, groups, layers, width: W, height: H, finest: 0, firstLayer: 0 };
    this.materials = [m];
    m.lData = new Float32Array(groups * layers * W * H * 4);
    m.lTex = this.texArray(gl.RGBA32F, W, H, groups * layers, gl.NEAREST);
    gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, 0, W, H, groups * layers, gl.RGBA, gl.FLOAT, m.lData);
    m.rData = new Float32Array(C * rows * 4);
    m.rTex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, m.rTex);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, C, rows);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, C, rows, gl.RGBA, gl.FLOAT, m.rData);
    const M = this.M;
    const vs = M._bw_pca_rings_program_source(0, C, k, lights);
    if (!vs) throw new Error(this.error());
    const vsrc = M.UTF8ToString(vs);
    m.program = this.link(vsrc, M.UTF8ToString(M._bw_pca_rings_program_source(1, C, k, lights)));
    const ringBlock = gl.getUniformBlockIndex(m.program, 'btflod_DirectionRings');
    if (ringBlock === gl.INVALID_INDEX) throw new Error('pca_rings program without btflod_DirectionRings');
    gl.uniformBlockBinding(m.program, ringBlock, RING_BLOCK_BINDING);
    m.ringUbo = gl.createBuffer();
    gl.bindBuffer(gl.UNIFORM_BUFFER, m.ringUbo);
    gl.bufferData(gl.UNIFORM_BUFFER, blockBytes, gl.STATIC_DRAW);
    gl.bindBufferBase(gl.UNIFORM_BUFFER, RING_BLOCK_BINDING, m.ringUbo);
    m.vao = this.planeVao(planeOrigin(0, 1));
    this.initFrameResources();
    this.opt.feedbackShift = 0;
    this.resize(this.canvas.width, this.canvas.height);
    this.totalBytes = head.total;
    this.nextChunk = 0;
    this.chunkInFlight = false;
    this.chunksApplied = 0;
    this.drawnSinceChunk = true;
    this.loaded = true;
  }

  /// fetchWithRetries plus the CRC-32 check: a payload whose CRC differs is counted, refused and
  /// requested again (at most 4 · maxRetries attempts, then an error). Resolves to the bytes.
  async fetchVerified(info, crc) {
    let attempt = 0;
    for (let tries = 0; tries < 4 * this.opt.maxRetries; ++tries) {
      const got = await this.fetchWithRetries(info, this.url || info.url, attempt);
      if (!got) break;
      attempt = got.attempt + 1;
      const p = this.heapCopy(got.bytes);
      const sum = this.M._bw_crc32(p, got.bytes.length) >>> 0;
      this.M._free(p);
      if (sum === crc >>> 0) return got.bytes;
      this.stats.corrupt += 1;  // refused: nothing of it reaches a texture
    }
    throw new Error(`chunk ${info.chunk}: no verified transfer after ${attempt} attempts`);
  }

  // Chunk c into the staging copies and the textures: 0 = ring block + mean (component 0 of L),
  // c ≥ 1 = component c of L (channel c % 4 of layer c / 4 of every group) and column c − 1 of R.
  applyChunk(c, bytes) {
    const gl = this.gl, m = this.materials[0];
    const n = m.width * m.height;
    let off = 0;
    if (c === 0) {
      gl.bindBuffer(gl.UNIFORM_BUFFER, m.ringUbo);
      gl.bufferSubData(gl.UNIFORM_BUFFER, 0, bytes.subarray(0, RING_BLOCK_BYTES));
      off = RING_BLOCK_BYTES;
    }
    const f = new Float32Array(bytes.buffer.slice(bytes.byteOffset + off, bytes.byteOffset + bytes.length));
    const layer = Math.floor(c / 4), ch = c % 4;
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, m.lTex);
    for (let b = 0; b < m.groups; ++b) {
      const z = b * m.layers + layer;
      const dst = m.lData.subarray(z * n * 4, (z + 1) * n * 4);
      for (let t = 0; t < n; ++t) dst[t * 4 + ch] = f[b * n + t];
      gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, z, m.width, m.height, 1, gl.RGBA, gl.FLOAT, dst);
    }
    if (c > 0) {
      const rows = m.lights * m.views, col = f.subarray(m.groups * n);
      for (let r = 0; r < rows; ++r) m.rData.set(col.subarray(r * 4, r * 4 + 4), (r * m.C + (c - 1)) * 4);
      gl.bindTexture(gl.TEXTURE_2D, m.rTex);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, m.C, rows, gl.RGBA, gl.FLOAT, m.rData);
    }
    this.chunksApplied += 1;
    this.stats.uploads += 1;
  }

  // Component by component (paper 004 §5): the next chunk is requested once the previous one has
  // been applied and drawn, so every frame shows at most one more component.
  pumpChunks() {
    if (this.chunkInFlight || this.nextChunk >= this.chunks.length || !this.drawnSinceChunk) return;
    const info = this.chunks[this.nextChunk++];
    this.chunkInFlight = true;
    this.fetchVerified(info, info.crc).then((bytes) => {
      this.applyChunk(info.chunk, bytes);
      this.drawnSinceChunk = false;
    }).catch((e) => {
      this.stats.failures += 1;
      this.nextChunk -= 1;  // asked again on a later frame
      console.warn(String(e));
    }).finally(() => { this.chunkInFlight = false; });
  }

  bindTextures(m) {
    const gl = this.gl;
    gl.activeTexture(gl.TEXTURE13); gl.bindTexture(gl.TEXTURE_2D_ARRAY, m.lTex);
    gl.activeTexture(gl.TEXTURE14); gl.bindTexture(gl.TEXTURE_2D, m.rTex);
  }

  frame() {
    const t0 = performance.now();
    this.drawColor();
    this.present();
    this.drawnSinceChunk = true;
    this.pumpChunks();
    this.updateQuality();
    this.stats.frames += 1;
    this.timeline.push({ t: performance.now() - this.startTime, bytes: this.stats.bytes, quality: this.quality() });
    this.frameMs = performance.now() - t0;
    return this.frameMs;
  }
  /// The SSIM estimate when a quality reference is set, else chunks delivered / all.
  quality() {
    if (this.qualityRef) return this.qualitySsim;
    return this.loaded ? this.chunksApplied / this.chunks.length : 0;
  }
  converged() { return !!this.loaded && this.chunksApplied === this.chunks.length && this.drawnSinceChunk; }
}
