# The paper profile deletes each material's BTF store right after its raw-BTF reference pass (one
# store on disk at a time); --keep-stores keeps them. Runs btflod-demo both ways on the same small
# configuration and checks that the transient run leaves no store behind, held at most one store
# at a time, and reports the same raw-BTF figures and reference images as the run that kept them.
# Arguments: -DDEMO=<btflod-demo> -DDIR=<scratch folder>.
file(REMOVE_RECURSE ${DIR})
set(common --profile paper --size 16 --materials 2 --frames 1 --settle 0 --frame-size 192x108 --memory 512M --quiet)
foreach(run transient keep)
  set(extra)
  if(run STREQUAL "keep")
    set(extra --keep-stores)
  endif()
  execute_process(COMMAND ${DEMO} --out ${DIR}/${run} ${common} ${extra} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "btflod-demo (${run}) failed (${rc}):\n${out}\n${err}")
  endif()
  file(READ ${DIR}/${run}/report.json json_${run})
  file(GLOB stores_${run} ${DIR}/${run}/*.btfstore ${DIR}/${run}/*.checkpoint)
endforeach()

list(LENGTH stores_transient n_transient)
list(LENGTH stores_keep n_keep)
if(NOT n_transient EQUAL 0)
  message(FATAL_ERROR "the transient run left stores behind: ${stores_transient}")
endif()
if(NOT n_keep EQUAL 2)
  message(FATAL_ERROR "--keep-stores kept ${n_keep} stores, expected 2: ${stores_keep}")
endif()

# The raw-BTF reference images are byte-identical.
foreach(png reference_raw.png reference_fmf_cpu.png)
  file(SHA256 ${DIR}/transient/${png} a)
  file(SHA256 ${DIR}/keep/${png} b)
  if(NOT a STREQUAL b)
    message(FATAL_ERROR "${png} differs between the transient and the --keep-stores run")
  endif()
endforeach()

# Fails unless both reports hold the same value at the JSON path <member or index>...; `label`
# names it in the message. Sets `a` to the value (in the caller's scope).
function(expect_same_in_both_reports label)
  string(JSON a GET "${json_transient}" ${ARGN})
  string(JSON b GET "${json_keep}" ${ARGN})
  if(NOT a STREQUAL b)
    message(FATAL_ERROR "${label}: ${a} (transient) vs ${b} (--keep-stores)")
  endif()
  set(a "${a}" PARENT_SCOPE)
endfunction()

# The same figures: the raw reference against the fully resident FMF on the GPU and on the CPU,
# the store bytes read, and each material's files (the BSVTF frame depends on streaming timing).
foreach(key fmf_gpu fmf_cpu)
  foreach(metric ssim psnr_db rmse)
    expect_same_in_both_reports("raw_reference.${key}.${metric}" raw_reference ${key} ${metric})
  endforeach()
endforeach()
expect_same_in_both_reports("raw_reference.store_bytes_read" raw_reference store_bytes_read)
if(a EQUAL 0)
  message(FATAL_ERROR "raw_reference.store_bytes_read: ${a} (transient) vs ${a} (--keep-stores)")
endif()
foreach(i 0 1)
  foreach(key raw_store_bytes fmf_half_bytes bsvtf_bytes)
    expect_same_in_both_reports("files[${i}].${key}" files ${i} ${key})
  endforeach()
endforeach()

# One store at a time: the transient run's peak is the kept run's less the first store.
string(JSON t_peak GET "${json_transient}" disk peak_bytes_in_output_folder)
string(JSON k_peak GET "${json_keep}" disk peak_bytes_in_output_folder)
string(JSON store0 GET "${json_keep}" files 0 raw_store_bytes)
string(JSON t_flag GET "${json_transient}" disk transient_stores)
string(JSON k_flag GET "${json_keep}" disk transient_stores)
math(EXPR bound "${k_peak} - ${store0}")
if(t_peak GREATER bound OR NOT t_flag STREQUAL "ON" OR NOT k_flag STREQUAL "OFF")
  message(FATAL_ERROR "disk: transient peak ${t_peak} (flag ${t_flag}) vs kept ${k_peak} (flag ${k_flag}) less the "
                      "first store ${store0}")
endif()
message(STATUS "transient stores: none left, peak ${t_peak} vs ${k_peak} bytes kept, same raw-BTF figures and images")
