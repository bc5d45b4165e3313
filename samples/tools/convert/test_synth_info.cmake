# convert_synth_info: synthesise a tiny material with btflod-convert, then read it back with
# `info --values`. Run with -DCONVERT=<btflod-convert> -DOUT=<scratch dir>.
include(${CMAKE_CURRENT_LIST_DIR}/convert_test_commands.cmake)
set(out ${OUT}/synth_test.btf)
file(REMOVE ${out})
convert_synth(Bonn "Bonn writer not compiled in; synth checked up to the writer" "synth failed"
              --material tiles --size 8 --seed 3 --components 8 --quiet -o ${out})
convert_info(info "info failed" --values ${out})
if(NOT info MATCHES "8 x 8" OR NOT info MATCHES "81 directions")
  message(FATAL_ERROR "info does not describe the 8x8 UBO2003 material it was given:\n${info}")
endif()
# synth stores rho*cos(theta_light): the Bonn cosine flag must say so (btflib: 1 = cosine in the data).
if(NOT info MATCHES "cosine in data: yes")
  message(FATAL_ERROR "synth wrote rho*cos(theta_light) but the file's cosine flag says otherwise:\n${info}")
endif()

# The same through a UBO2003-style PNG folder (any output path not ending in .btf).
set(folder ${OUT}/synth_test_folder)
file(REMOVE_RECURSE ${folder})
convert_synth(UBO2003 "folder writer not compiled in" "synth to a folder failed"
              --material cloth --size 4 --seed 5 --quiet -o ${folder})
convert_info(info "info on the folder failed" ${folder})
if(NOT info MATCHES "6561 images" OR NOT info MATCHES "4 x 4")
  message(FATAL_ERROR "info does not describe the 4x4 UBO2003 folder it was given:\n${info}")
endif()
