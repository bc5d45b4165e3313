# Included by the convert_* test scripts (run with -DCONVERT=<btflod-convert>).
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
