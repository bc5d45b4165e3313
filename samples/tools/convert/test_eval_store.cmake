# convert_eval_store: `eval` against a BTF store streamed from disk. synth writes a store, factor
# writes an FMF, eval prints its error table with a budget of a few images per group and with one
# holding every image of a view: the tables must be identical (the in-memory equality is
# tests/test_metrics_btf_store.cpp's); a budget below one image pair is refused, naming the minimum.
# Run with -DCONVERT=<btflod-convert> -DOUT=<scratch dir>.
set(store ${OUT}/eval_test.btfstore)
set(fmf ${OUT}/eval_test.fmf)
file(REMOVE ${store} ${fmf})
execute_process(COMMAND ${CONVERT} synth --material cloth --size 16 --quiet -o ${store}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "synth to a store failed (${rc}): ${err}")
endif()
execute_process(COMMAND ${CONVERT} factor ${store} ${fmf} --components 8 --memory 256M --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "factor of the store failed (${rc}):\n${out}\n${err}")
endif()
set(tables "")
foreach(memory 600K 1G)
  execute_process(COMMAND ${CONVERT} eval ${fmf} ${store} --memory ${memory}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "\\| fmf \\|" OR NOT out MATCHES "streamed from the store")
    message(FATAL_ERROR "eval against the store (--memory ${memory}) failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "--memory ${memory}:\n${out}")
  string(REGEX MATCH "\\| [^\n]*\\| fmf \\|[^\n]*" row "${out}")
  list(APPEND tables "${row}")
endforeach()
list(GET tables 0 small)
list(GET tables 1 large)
if(NOT small STREQUAL large)
  message(FATAL_ERROR "eval differs with the budget:\n${small}\n${large}")
endif()
if(NOT out MATCHES "81 light groups of 81 images")
  message(FATAL_ERROR "a 1G budget should hold every light of a view: ${out}")
endif()
execute_process(COMMAND ${CONVERT} eval ${fmf} ${store} --memory 10K
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "needs at least")
  message(FATAL_ERROR "a 10 KiB budget should be refused with the minimum named (${rc}): ${out}${err}")
endif()
file(REMOVE ${store} ${fmf})
