# Every btflod-demo option does what its help says or is refused. Runs the demo on tiny
# configurations (one material, one 96 x 54 frame, no settle) and checks report.json:
#   --components C: the configuration states C and the FMF written has rank C (its U and V as
#                   halves are C · (directions² · 3 + texels²) · 2 bytes);
#   --rank-target S: the material's rank is the smallest candidate reaching S on its displayed images;
#   --material NAME: every material is NAME; --interreflection changes the synthesised BTF;
# and that unknown options and out-of-range values exit with 2 and say what is wrong.
# Arguments: -DDEMO=<btflod-demo> -DDIR=<scratch folder>.
file(REMOVE_RECURSE ${DIR})
set(tiny --materials 1 --frames 1 --settle 0 --frame-size 96x54 --quiet)

function(run_demo name)
  execute_process(COMMAND ${DEMO} --out ${DIR}/${name} ${tiny} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "btflod-demo ${ARGN} failed (${rc}):\n${out}\n${err}")
  endif()
  file(READ ${DIR}/${name}/report.json json)
  set(json "${json}" PARENT_SCOPE)
  set(out "${out}" PARENT_SCOPE)
endfunction()

function(check_rank json want)
  string(JSON c GET "${json}" configuration components)
  string(JSON d GET "${json}" configuration directions)
  string(JSON t GET "${json}" configuration material_texels)
  string(JSON bytes GET "${json}" files 0 fmf_half_bytes)
  math(EXPR expect "${want} * (${d} * ${d} * 3 + ${t} * ${t}) * 2")
  if(NOT c EQUAL want OR NOT bytes EQUAL expect)
    message(FATAL_ERROR "C = ${want} asked: report says C = ${c}, FMF of ${bytes} bytes (rank ${want}: ${expect})")
  endif()
endfunction()

run_demo(c12 --components 12)
check_rank("${json}" 12)
string(JSON is_default GET "${json}" configuration components_default)
if(is_default)
  message(FATAL_ERROR "--components 12: the report calls C the default")
endif()
string(FIND "${out}" "FMF C=12" at)
if(at EQUAL -1)
  message(FATAL_ERROR "--components 12: stdout does not say FMF C=12:\n${out}")
endif()
# The per-material comparison with the raw BTF names its rays and filter.
string(JSON filter GET "${json}" raw_reference per_material 0 fmf_cpu filter)
string(JSON p99 GET "${json}" raw_reference per_material 0 fmf_cpu delta_e_p99)
if(NOT filter MATCHES "^same rays" OR p99 STREQUAL "")
  message(FATAL_ERROR "raw_reference.per_material[0].fmf_cpu: filter '${filter}', delta_e_p99 '${p99}'")
endif()

run_demo(c5 --components 5)
check_rank("${json}" 5)

# --rank-target S: the material's rank is the first candidate whose training-view SSIM reaches S
# (the curve stops there, and the candidate before it fell short); the programs' C is that rank.
run_demo(rank --rank-target 0.6 --components 12)
string(JSON c GET "${json}" configuration components)
string(JSON target GET "${json}" configuration rank_target_ssim)
string(JSON chosen GET "${json}" files 0 components)
string(JSON points LENGTH "${json}" files 0 rank_curve)
math(EXPR last "${points} - 1")
string(JSON last_c GET "${json}" files 0 rank_curve ${last} components)
string(JSON last_ssim GET "${json}" files 0 rank_curve ${last} training_ssim)
if(NOT c EQUAL chosen OR NOT last_c EQUAL chosen OR NOT target EQUAL 0.6 OR chosen GREATER 12)
  message(FATAL_ERROR "--rank-target 0.6: programs' C ${c}, material C ${chosen}, curve ends at C ${last_c}, "
                      "target ${target}")
endif()
if(last_ssim LESS 0.6 AND chosen LESS 12)
  message(FATAL_ERROR "--rank-target 0.6: chose C ${chosen} at training SSIM ${last_ssim}")
endif()
if(points GREATER 1)
  math(EXPR before "${points} - 2")
  string(JSON before_ssim GET "${json}" files 0 rank_curve ${before} training_ssim)
  if(NOT before_ssim LESS 0.6)
    message(FATAL_ERROR "--rank-target 0.6: a smaller rank already reached it (${before_ssim})")
  endif()
endif()
check_rank("${json}" ${chosen})

run_demo(tiles --material tiles)
string(JSON name GET "${json}" files 0 material)
if(NOT name STREQUAL "tiles-0")
  message(FATAL_ERROR "--material tiles: the material is ${name}")
endif()
run_demo(tiles_ir --material tiles --interreflection)
file(SHA256 ${DIR}/tiles/tiles-0.btfstore plain)
file(SHA256 ${DIR}/tiles_ir/tiles-0.btfstore bounced)
if(plain STREQUAL bounced)
  message(FATAL_ERROR "--interreflection did not change the synthesised BTF")
endif()

# Refused: exit code 2 and a message naming the problem.
foreach(case "--bogus-flag;unknown option --bogus-flag" "--bogus-option;3;unknown option --bogus-option"
             "--components;0;--components 0: expected an integer in [1, 128]" "--components;129;--components 129: expected an integer in [1, 128]"
             "--material;glass;--material glass: expected cloth, stone, leather or tiles"
             "--components;needs a value" "--cache-format;bc7;--cache-format bc7: expected rgba16f, rgba8, rgba8_affine, bc5 or bc5_affine"
             "--rank-target;1.5;--rank-target 1.5: expected a number in [0, 1]"
             "--brdf;${DIR}/no_such.mbsdf;--brdf ${DIR}/no_such.mbsdf:")
  list(POP_BACK case message)
  execute_process(COMMAND ${DEMO} --out ${DIR}/refused ${case} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  string(FIND "${err}" "${message}" at)
  if(NOT rc EQUAL 2 OR at EQUAL -1)
    message(FATAL_ERROR "btflod-demo ${case}: exit ${rc} (expected 2), stderr lacks '${message}':\n${err}")
  endif()
endforeach()
message(STATUS "btflod-demo options: --components, --rank-target, --material, --interreflection work; bad options refused")
