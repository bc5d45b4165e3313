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

# The same figures: the raw reference against the fully resident FMF on the GPU and on the CPU,
# the store bytes read, and each material's files (the BSVTF frame depends on streaming timing).
foreach(key fmf_gpu fmf_cpu)
  foreach(metric ssim psnr_db rmse)
    string(JSON a GET "${json_transient}" raw_reference ${key} ${metric})
    string(JSON b GET "${json_keep}" raw_reference ${key} ${metric})
    if(NOT a STREQUAL b)
      message(FATAL_ERROR "raw_reference.${key}.${metric}: ${a} (transient) vs ${b} (--keep-stores)")
    endif()
  endforeach()
endforeach()
string(JSON a GET "${json_transient}" raw_reference store_bytes_read)
string(JSON b GET "${json_keep}" raw_reference store_bytes_read)
if(NOT a STREQUAL b OR a EQUAL 0)
  message(FATAL_ERROR "raw_reference.store_bytes_read: ${a} (transient) vs ${b} (--keep-stores)")
endif()
foreach(i 0 1)
  foreach(key raw_store_bytes fmf_half_bytes bsvtf_bytes)
    string(JSON a GET "${json_transient}" files ${i} ${key})
    string(JSON b GET "${json_keep}" files ${i} ${key})
    if(NOT a STREQUAL b)
      message(FATAL_ERROR "files[${i}].${key}: ${a} (transient) vs ${b} (--keep-stores)")
    endif()
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
