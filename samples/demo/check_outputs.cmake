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
# --cut: frames and bytes to converge after the camera cut, measured and consistent: the first
# frame after the cut is far from the converged one (the first view's tiles were not resident),
# streaming went quiet, and reaching SSIM 0.99 took frames and tile uploads (bytes from the link
# may be 0: the payload cache holds the whole small data set once read).
string(JSON cut_frames GET "${json}" cut frames_to_threshold)
string(JSON cut_tiles GET "${json}" cut tiles_to_threshold)
string(JSON cut_run GET "${json}" cut frames_run)
string(JSON cut_quiet GET "${json}" cut quiet)
string(JSON cut_first GET "${json}" cut first_frame_ssim)
if(cut_frames LESS 2 OR cut_frames GREATER cut_run OR cut_tiles EQUAL 0 OR NOT cut_quiet OR NOT cut_first LESS 0.99)
  message(FATAL_ERROR "report.json cut: ${cut_frames} frames (of ${cut_run}, quiet ${cut_quiet}), ${cut_tiles} tiles, "
                      "first frame SSIM ${cut_first}")
endif()
message(STATUS "cut: within SSIM 0.99 after ${cut_frames} frames, ${cut_tiles} tiles")
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
file(READ ${DIR}/report.html html)
string(FIND "${html}" "<svg" at)
if(at EQUAL -1)
  message(FATAL_ERROR "report.html has no inline SVG plot")
endif()
message(STATUS "btflod-demo outputs present")
