// Decodes every tile of a .bsvtf file with the WebAssembly decoder under Node (no browser) and
// prints the hash and timings as JSON: the wasm twin of `btflod-web-tool decode`.
// Usage: node --no-experimental-fetch node_decode.mjs <module.js> <file.bsvtf> [repeats] [backend 0|1]
import { readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const [modulePath, file, repeats = '3', backend = '0'] = process.argv.slice(2);
const require = createRequire(import.meta.url);
const createBtflodModule = require(path.resolve(modulePath));
const M = await createBtflodModule();
const bytes = readFileSync(file);
const ptr = M._malloc(bytes.length);
M.HEAPU8.set(bytes, ptr);
const out = M._malloc(5 * 8);
const status = M._bw_decode_container(ptr, bytes.length, Number(backend), Number(repeats), out);
const r = new Float64Array(M.HEAPU8.buffer, out, 5);
console.log(JSON.stringify({ status, hash_lo: r[0], hash_hi: r[1], tiles: r[2] / Number(repeats), decode_us: r[3], inflate_us: r[4] }));
