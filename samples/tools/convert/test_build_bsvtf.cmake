# convert_build_bsvtf: synthesise a small leather, factor it (FMF), build .bsvtf containers with
# the default (perceptual) and the shared tolerance and check that both decode completely
# (`info --values`), that the default is the perceptual one with its frequency weighting, and
# that it differs from the shared one; an unknown --tolerance is a usage error. The same material
# factorised on ln(x + 0.05) with the rank chosen from a displayed-SSIM target builds a container
# that says so (`values log`) and decodes completely.
# Run with -DCONVERT=<btflod-convert> -DOUT=<scratch dir>.
include(${CMAKE_CURRENT_LIST_DIR}/convert_test_commands.cmake)
set(btf ${OUT}/build_test.btf)
set(fmf ${OUT}/build_test.fmf)
foreach(f ${btf} ${fmf} ${OUT}/build_p.bsvtf ${OUT}/build_s.bsvtf)
  file(REMOVE ${f})
endforeach()
convert_synth(Bonn "Bonn writer not compiled in" "synth failed" --material leather --size 32 --seed 3 --quiet -o ${btf})
execute_process(COMMAND ${CONVERT} factor ${btf} ${fmf} --method fmf --components 8 --quiet
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "factor failed (${rc}): ${err}")
endif()
execute_process(COMMAND ${CONVERT} build ${fmf} ${OUT}/build_p.bsvtf --tile 16 --border 4 --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "tolerances perceptual" OR NOT out MATCHES "weighting JPEG\\^\\(1/4\\)")
  message(FATAL_ERROR "default build failed or is not perceptual (${rc}): ${out} ${err}")
endif()
execute_process(COMMAND ${CONVERT} build ${fmf} ${OUT}/build_s.bsvtf --tile 16 --border 4 --tolerance shared --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "tolerances shared, weighting JPEG\\^\\(4/4\\)")
  message(FATAL_ERROR "shared build failed (${rc}): ${out} ${err}")
endif()
foreach(f build_p build_s)
  execute_process(COMMAND ${CONVERT} info --values ${OUT}/${f}.bsvtf RESULT_VARIABLE rc OUTPUT_VARIABLE info ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT info MATCHES "10 tiles decoded, 0 failed")
    message(FATAL_ERROR "info --values on ${f}.bsvtf (${rc}): ${info} ${err}")
  endif()
endforeach()
file(READ ${OUT}/build_p.bsvtf a HEX)
file(READ ${OUT}/build_s.bsvtf b HEX)
if(a STREQUAL b)
  message(FATAL_ERROR "perceptual and shared tolerances wrote the same file")
endif()
execute_process(COMMAND ${CONVERT} build ${fmf} ${OUT}/build_x.bsvtf --tolerance bogus RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "expected perceptual, shared or per-component")
  message(FATAL_ERROR "an unknown --tolerance was accepted (${rc}): ${err}")
endif()

execute_process(COMMAND ${CONVERT} factor ${btf} ${OUT}/build_log.fmf --method fmf --components 16 --value-encoding log
                        --target-ssim 0.5 --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "chose C = [0-9]+ \\(meets the target 0.5000\\)" OR NOT out MATCHES "held-out views")
  message(FATAL_ERROR "factor --value-encoding log --target-ssim failed (${rc}): ${out} ${err}")
endif()
message(STATUS "${out}")
execute_process(COMMAND ${CONVERT} build ${OUT}/build_log.fmf ${OUT}/build_log.bsvtf --tile 16 --border 4 --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "build of the log-encoded FMF failed (${rc}): ${out} ${err}")
endif()
execute_process(COMMAND ${CONVERT} info --values ${OUT}/build_log.bsvtf RESULT_VARIABLE rc OUTPUT_VARIABLE info ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT info MATCHES "values log \\(offset 0.05\\)" OR NOT info MATCHES " tiles decoded, 0 failed")
  message(FATAL_ERROR "info --values on build_log.bsvtf (${rc}): ${info} ${err}")
endif()
# Decorrelated colour (log luminance, chroma over it): factor, build, and every tile decodes.
execute_process(COMMAND ${CONVERT} factor ${btf} ${OUT}/build_ycc.fmf --method fmf --components 8
                        --value-encoding log_ycbcr --quiet RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "factor --value-encoding log_ycbcr failed (${rc}): ${out} ${err}")
endif()
execute_process(COMMAND ${CONVERT} build ${OUT}/build_ycc.fmf ${OUT}/build_ycc.bsvtf --tile 16 --border 4 --quiet
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
execute_process(COMMAND ${CONVERT} info --values ${OUT}/build_ycc.bsvtf RESULT_VARIABLE rc2 OUTPUT_VARIABLE info
                ERROR_VARIABLE err2)
if(NOT rc EQUAL 0 OR NOT rc2 EQUAL 0 OR NOT info MATCHES "values log_ycbcr \\(offset 0.05\\)"
   OR NOT info MATCHES " tiles decoded, 0 failed")
  message(FATAL_ERROR "build/info of the log_ycbcr FMF (${rc}, ${rc2}): ${out} ${err} ${info} ${err2}")
endif()
execute_process(COMMAND ${CONVERT} factor ${btf} ${OUT}/build_x.fmf --method pca-k --target-ssim 0.9
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "only the fmf method chooses its rank")
  message(FATAL_ERROR "--target-ssim with pca-k was accepted (${rc}): ${err}")
endif()
