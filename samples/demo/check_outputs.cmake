# Checks the files btflod-demo writes (run after demo_streaming_small): report.json with the
# memory and frame-time figures, report.html with inline SVG, the contact sheet and frames.
foreach(f report.json report.html contact_sheet_frames.png frames/frame_0000.png frames/frame_0023.png reference_raw.png
        reference_fmf_cpu.png)
  if(NOT EXISTS ${DIR}/${f})
    message(FATAL_ERROR "btflod-demo did not write ${DIR}/${f}")
  endif()
endforeach()
file(READ ${DIR}/report.json json)
foreach(key fmf_texture_bytes bsvtf_texture_bytes median_ms_bsvtf median_ms_fmf bytes_received ssim raw_reference
        bsvtf_gpu fmf_cpu paper000 raw_store_bytes per_material delta_e_p99 filter components_default)
  string(FIND "${json}" "\"${key}\"" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "report.json lacks ${key}")
  endif()
endforeach()
# The run used the default rank and says so; every comparison with the raw BTF names its rays and filter.
string(JSON is_default GET "${json}" configuration components_default)
string(JSON filter GET "${json}" raw_reference fmf_cpu filter)
string(JSON other GET "${json}" raw_reference fmf_gpu filter)
if(NOT is_default OR NOT filter MATCHES "^same rays" OR NOT other MATCHES "^different filters")
  message(FATAL_ERROR "report.json: components_default ${is_default}, fmf_cpu filter '${filter}', fmf_gpu filter '${other}'")
endif()
# --cut: frames and bytes to converge after the camera cut, measured and consistent: some frame
# after the cut is below SSIM 0.99 of the converged one (the first view's tiles were not all
# resident; with the log encoding the very first frame may already be within it, and frames dip
# below while finer tiles arrive), streaming went quiet, and staying within SSIM 0.99 took frames
# and tile uploads (bytes from the link may be 0: the payload cache holds the whole small data set).
string(JSON cut_frames GET "${json}" cut frames_to_threshold)
string(JSON cut_tiles GET "${json}" cut tiles_to_threshold)
string(JSON cut_run GET "${json}" cut frames_run)
string(JSON cut_quiet GET "${json}" cut quiet)
string(JSON cut_count LENGTH "${json}" cut ssim)
set(cut_min 1)
math(EXPR cut_last "${cut_count} - 1")
foreach(i RANGE ${cut_last})
  string(JSON s GET "${json}" cut ssim ${i})
  if(s LESS cut_min)
    set(cut_min ${s})
  endif()
endforeach()
if(cut_frames LESS 2 OR cut_frames GREATER cut_run OR cut_tiles EQUAL 0 OR NOT cut_quiet OR NOT cut_min LESS 0.99)
  message(FATAL_ERROR "report.json cut: ${cut_frames} frames (of ${cut_run}, quiet ${cut_quiet}), ${cut_tiles} tiles, "
                      "lowest SSIM after the cut ${cut_min}")
endif()
message(STATUS "cut: within SSIM 0.99 after ${cut_frames} frames, ${cut_tiles} tiles (lowest ${cut_min})")
# The two material swaps on the live Streamer: each added material was shown (after it was
# ready) and the id it replaced released, in order; the swap back takes the freed layers again.
string(JSON planned GET "${json}" material_swaps planned)
string(JSON swap_count LENGTH "${json}" material_swaps swaps)
if(NOT planned EQUAL 2 OR NOT swap_count EQUAL 2)
  message(FATAL_ERROR "report.json material_swaps: ${swap_count} of ${planned} planned, expected 2 of 2")
endif()
foreach(i 0 1)
  string(JSON added GET "${json}" material_swaps swaps ${i} added_frame)
  string(JSON shown GET "${json}" material_swaps swaps ${i} shown_frame)
  string(JSON released GET "${json}" material_swaps swaps ${i} released_frame)
  if(shown LESS added OR released LESS shown)
    message(FATAL_ERROR "report.json swap ${i}: added ${added}, shown ${shown}, released ${released}")
  endif()
endforeach()
string(JSON first_out GET "${json}" material_swaps swaps 0 removed_id)
string(JSON back_id GET "${json}" material_swaps swaps 1 added_id)
message(STATUS "material swaps: 2 of 2, material ${first_out} out and back as ${back_id}")
# The cache format: rgba8_affine by default, half the bytes of rgba16f, and on the settled view
# (same rays, tiles and page table) within the invisible threshold of rgba16f (ΔE*ab p99 < 0.5).
string(JSON cf_format GET "${json}" cache_format format)
string(JSON cf_16 GET "${json}" cache_format cache_bytes_rgba16f)
string(JSON cf_8 GET "${json}" cache_format cache_bytes_rgba8)
string(JSON cf_de GET "${json}" cache_format rgba8_vs_rgba16f delta_e_p99)
string(JSON cf_ssim GET "${json}" cache_format rgba8_vs_rgba16f ssim)
math(EXPR cf_half "${cf_16} * 51 / 100")
if(NOT cf_format STREQUAL "rgba8_affine" OR cf_8 GREATER cf_half OR NOT cf_de LESS 0.5 OR cf_ssim LESS 0.999)
  message(FATAL_ERROR "report.json cache_format: ${cf_format}, ${cf_8} vs ${cf_16} bytes, rgba8 vs rgba16f "
                      "dE p99 ${cf_de} SSIM ${cf_ssim}")
endif()
message(STATUS "cache format ${cf_format}: ${cf_8} of ${cf_16} bytes, dE*ab p99 ${cf_de} against rgba16f")
file(READ ${DIR}/report.html html)
string(FIND "${html}" "<svg" at)
if(at EQUAL -1)
  message(FATAL_ERROR "report.html has no inline SVG plot")
endif()
message(STATUS "btflod-demo outputs present")
