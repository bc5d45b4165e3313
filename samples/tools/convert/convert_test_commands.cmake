# Included by the convert_* test scripts (run with -DCONVERT=<btflod-convert>): the commands they
# run with the checks every run needs.
#
# convert_synth(<writer> <skip message> <failure message> <synth arguments>...): runs
# `btflod-convert synth <synth arguments>`. When it fails because the output's writer is not
# compiled in (its error says "has no <writer>"), prints "<skip message>: <error>" and ends the
# calling script, which passes; any other failure ends the test with "<failure message>".
macro(convert_synth writer skip_message failure_message)
  execute_process(COMMAND ${CONVERT} synth ${ARGN} RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    if(err MATCHES "has no ${writer}")
      message(STATUS "${skip_message}: ${err}")
      return()
    endif()
    message(FATAL_ERROR "${failure_message} (${rc}): ${err}")
  endif()
endmacro()

# convert_info(<out_var> <failure message> <info arguments>...): runs `btflod-convert info
# <info arguments>`, prints its output and sets <out_var> to it; a failure ends the test with
# "<failure message>".
macro(convert_info out_var failure_message)
  execute_process(COMMAND ${CONVERT} info ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE ${out_var} ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${failure_message} (${rc}): ${err}")
  endif()
  message(STATUS "${${out_var}}")
endmacro()
