# convert_store_factor: the out-of-core path of the CLI end to end. synth writes a BTF store,
# factor stops after pass 1 (as a killed run would), the same command resumes from the
# checkpoint, and the result is a factor file `build` codes into a container. Run with -DCONVERT=<btflod-convert>
# -DOUT=<scratch dir>.
set(store ${OUT}/store_test.btfstore)
set(fmf ${OUT}/store_test.fmf)
file(REMOVE ${store} ${fmf} ${fmf}.checkpoint)
execute_process(COMMAND ${CONVERT} synth --material stone --size 16 --quiet -o ${store}
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "synth to a store failed (${rc}): ${err}")
endif()
execute_process(COMMAND ${CONVERT} factor ${store} ${fmf} --components 8 --memory 256M --stop-after-passes 1 --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "stopped after pass 1" OR NOT err MATCHES "resume" OR NOT EXISTS ${fmf}.checkpoint)
  message(FATAL_ERROR "factor --stop-after-passes 1 should stop with a checkpoint (${rc}):\n${out}\n${err}")
endif()
execute_process(COMMAND ${CONVERT} factor ${store} ${fmf} --components 8 --memory 256M --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "\\(\\+1 resumed\\)" OR EXISTS ${fmf}.checkpoint)
  message(FATAL_ERROR "the resumed factor run failed or did not resume (${rc}):\n${out}\n${err}")
endif()
message(STATUS "${out}")
execute_process(COMMAND ${CONVERT} factor ${store} ${fmf} --components 8 --memory 1K --quiet
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "the budget is")
  message(FATAL_ERROR "a 1 KiB budget should be refused with the minimum named (${rc}): ${err}")
endif()
execute_process(COMMAND ${CONVERT} build ${fmf} ${OUT}/store_test.bsvtf --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE info ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT info MATCHES "16x16, 8 components")
  message(FATAL_ERROR "build of the out-of-core factor file failed (${rc}):\n${info}\n${err}")
endif()
file(REMOVE ${store} ${fmf} ${OUT}/store_test.bsvtf)
