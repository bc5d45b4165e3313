# ctest bench_cli_reports: btflod-bench on a tiny generated trace + container.
#   -DBENCH=<btflod-bench> -DOUT=<scratch folder>
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})

function(run_bench expect_ok out_var)
  execute_process(COMMAND ${BENCH} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(expect_ok AND NOT rc EQUAL 0)
    message(FATAL_ERROR "btflod-bench ${ARGN} failed (${rc}):\n${out}\n${err}")
  endif()
  if(NOT expect_ok AND rc EQUAL 0)
    message(FATAL_ERROR "btflod-bench ${ARGN} should have failed:\n${out}\n${err}")
  endif()
  set(${out_var} "${out}${err}" PARENT_SCOPE)
endfunction()

run_bench(TRUE out generate --trace ${OUT}/t.btftrace --bsvtf ${OUT}/m.bsvtf --frames 32 --width 64 --height 36 --texture 256)

# Replay (scheduler + cache, and the runtime Streamer with --runtime): the same trace replayed in
# every repetition gives the same schedule bit for bit.
run_bench(TRUE out scheduler --trace ${OUT}/t.btftrace --bsvtf ${OUT}/m.bsvtf --slots 12 --uploads 2 --repeat 3
          --json ${OUT}/a.json --check-determinism --runtime)
if(NOT out MATCHES "deterministic: yes")
  message(FATAL_ERROR "replay not deterministic:\n${out}")
endif()
if(NOT out MATCHES "update \\+ decode +p50 +[0-9.]+ us")
  message(FATAL_ERROR "no runtime replay in the scheduler report:\n${out}")
endif()
if(NOT out MATCHES "frame CPU time +p50 +[0-9.]+ us")
  message(FATAL_ERROR "no percentiles in the scheduler report:\n${out}")
endif()
file(READ ${OUT}/a.json a_json)
foreach(key "\"format\": \"btflod-bench-report\"" "frame_cpu_us.p99" "x_read.p50" "bytes_requested" "budget_hits.upload")
  string(FIND "${a_json}" "${key}" at)
  if(at LESS 0)
    message(FATAL_ERROR "a.json lacks ${key}")
  endif()
endforeach()

# Described materials instead of a container (the trace's material 0).
run_bench(TRUE out scheduler --trace ${OUT}/t.btftrace --materials 1 --texture 256 --components 8 --slots 16 --repeat 1)

# Sweep: CSV with one row per configuration (+ header) and an SVG plot.
run_bench(TRUE out scheduler --trace ${OUT}/t.btftrace --bsvtf ${OUT}/m.bsvtf --sweep --sweep-slots 8,16 --sweep-uploads 2,4
          --sweep-modes weighted,votes-only --repeat 1 --csv ${OUT}/s.csv --svg ${OUT}/s.svg --json ${OUT}/s.json)
file(STRINGS ${OUT}/s.csv csv_lines)
list(LENGTH csv_lines n)
if(NOT n EQUAL 9)
  message(FATAL_ERROR "sweep CSV has ${n} lines, expected 9")
endif()
file(READ ${OUT}/s.svg svg)
if(NOT svg MATCHES "<polyline" OR NOT svg MATCHES "</svg>")
  message(FATAL_ERROR "sweep SVG has no plot")
endif()

# Codec: every tile decoded, per level, with the baselines; encode at two qualities.
run_bench(TRUE out codec --bsvtf ${OUT}/m.bsvtf --repeat 2 --encode --quality 30,80 --json ${OUT}/c.json)
if(NOT out MATCHES "btflod_zlib" OR NOT out MATCHES "zlib_raw_halves" OR NOT out MATCHES "encode btflod q30")
  message(FATAL_ERROR "codec report incomplete:\n${out}")
endif()

# compare: a report against itself has no regression; a copy with one timing made 1000x worse
# is flagged (exit 1) with the metric's name.
run_bench(TRUE out compare ${OUT}/a.json ${OUT}/a.json)
if(NOT out MATCHES "0 regressions")
  message(FATAL_ERROR "self-comparison flagged something:\n${out}")
endif()
string(REGEX MATCH "\"name\": \"frame_cpu_us.p95\", \"value\": ([0-9.e+-]+)" m "${a_json}")
set(old_value ${CMAKE_MATCH_1})
string(REGEX REPLACE "(\"name\": \"frame_cpu_us.p95\", \"value\": )[0-9.e+-]+" "\\1${old_value}e3" b_json "${a_json}")
file(WRITE ${OUT}/b.json "${b_json}")
run_bench(FALSE out compare ${OUT}/a.json ${OUT}/b.json)
if(NOT out MATCHES "frame_cpu_us.p95[^\n]*REGRESSION" OR NOT out MATCHES "1 regressions")
  message(FATAL_ERROR "injected regression not flagged:\n${out}")
endif()
run_bench(FALSE out compare ${OUT}/a.json ${OUT}/c.json)  # different kinds of report

# Corrupt and truncated traces are refused with a clear message.
# A trace cut 100 bytes short (inside the last frame's payload or end record).
find_program(HEAD head)
if(HEAD)
  file(SIZE ${OUT}/t.btftrace size)
  math(EXPR keep "${size} - 100")
  execute_process(COMMAND ${HEAD} -c ${keep} ${OUT}/t.btftrace OUTPUT_FILE ${OUT}/truncated.btftrace)
  run_bench(FALSE out scheduler --trace ${OUT}/truncated.btftrace --bsvtf ${OUT}/m.bsvtf)
  if(NOT out MATCHES "cannot use the trace: .*(truncated|left in the file)")
    message(FATAL_ERROR "truncated trace not refused clearly:\n${out}")
  endif()
endif()
file(WRITE ${OUT}/text.btftrace "not a trace at all, just some text that is long enough to hold a header ...")
run_bench(FALSE out scheduler --trace ${OUT}/text.btftrace --bsvtf ${OUT}/m.bsvtf)
if(NOT out MATCHES "wrong signature")
  message(FATAL_ERROR "text file not refused clearly:\n${out}")
endif()
message(STATUS "bench_cli_reports: all checks passed")
