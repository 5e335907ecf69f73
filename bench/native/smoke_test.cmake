# ctest bench_smoke: arap-bench on tiny procedural meshes and on a 12-vertex
# box given both as an OFF file and as a scenario JSON; checks the exit code
# and that results.md / results.json hold a row for every mesh; where CGAL is installed (CGAL_INSTALLED),
# that the benchmark compares with it.
# Runs arap-bench with the arguments given; stops the test when it fails.
function(run_bench)
  execute_process(COMMAND ${BENCH} ${ARGN} RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "arap-bench ${ARGN} exited with ${status}")
  endif()
endfunction()

file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
# 1 x 1 x 2 box with a middle ring: 12 vertices, 20 outward triangles.
file(WRITE ${WORK}/box.off "OFF\n12 20 0\n"
  "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n0 0 2\n1 0 2\n1 1 2\n0 1 2\n"
  "3 0 2 1\n3 0 3 2\n3 8 9 10\n3 8 10 11\n")
foreach(ring 0 4)
  foreach(side 0 1 2 3)
    math(EXPR a "${ring} + ${side}")
    math(EXPR b "${ring} + (${side} + 1) % 4")
    math(EXPR c "${b} + 4")
    math(EXPR d "${a} + 4")
    file(APPEND ${WORK}/box.off "3 ${a} ${b} ${c}\n3 ${a} ${c} ${d}\n")
  endforeach()
endforeach()
file(WRITE ${WORK}/box.json
  "{\"name\": \"box-scenario\", \"mesh\": \"box.off\", \"fixed\": [0, 1, 2, 3],"
  " \"handles\": [{\"vertices\": [8, 9, 10, 11], \"translate\": [0.5, 0, 0]}]}\n")

run_bench(--min-vertices 300 --max-vertices 600 --iterations 6 --weights cotan,cotan-clamped
          --threads 1,2 --anderson 3 --cgal-iterations 3 --output-dir ${WORK}/results ${WORK}/box.off ${WORK}/box.json)
file(READ ${WORK}/results/results.md table)
foreach(name "sphere-[0-9]+" "bar-[0-9]+" box box-scenario)
  if(NOT table MATCHES "\\| ${name} \\| [0-9]+ \\| cotan")
    message(FATAL_ERROR "results.md has no row for ${name}:\n${table}")
  endif()
endforeach()
file(READ ${WORK}/results/results.json doc)
string(JSON meshes LENGTH "${doc}" meshes)
if(NOT meshes EQUAL 6)
  message(FATAL_ERROR "results.json lists ${meshes} meshes, expected 6")
endif()
# Where configure found CGAL (libcgal-dev installed), the benchmark compares with it: a build that lost its
# peer fails here instead of running without its CGAL columns.
string(JSON cgal GET "${doc}" cgal_available)
if(CGAL_INSTALLED AND NOT cgal)
  message(FATAL_ERROR "CGAL is installed, but arap-bench was built without the CGAL comparison")
endif()
if(cgal)
  string(JSON preprocess ERROR_VARIABLE no_cgal GET "${doc}" meshes 0 cgal preprocess_ms)
  if(no_cgal)
    message(FATAL_ERROR "arap-bench has CGAL but measured no CGAL preprocess:\n${no_cgal}")
  endif()
endif()

# The time-to-band mode: every method on the box scenario, a short budget.
run_bench(--time-to-band --band-iterations 40 --shapes none --output-dir ${WORK}/band ${WORK}/box.json)
file(READ ${WORK}/band/band.md table)
if(NOT table MATCHES "\\| box-scenario \\| 12 \\| [0-9]+ / ")
  message(FATAL_ERROR "band.md has no row for box-scenario:\n${table}")
endif()

# --band-extend: with a budget too short for local-global, its run is resumed until it enters the band.
run_bench(--time-to-band --band-iterations 4 --band-extend 2000 --shapes bar --sizes 1000 --no-cgal
          --output-dir ${WORK}/band_extend)
file(READ ${WORK}/band_extend/band.json doc)
string(JSON plain GET "${doc}" meshes 0 runs 0)
string(JSON method GET "${plain}" method)
string(JSON extended ERROR_VARIABLE no_flag GET "${plain}" extended)
string(JSON k GET "${plain}" iterations_to_band)
if(NOT method STREQUAL "local-global" OR NOT extended OR k LESS_EQUAL 4)
  message(FATAL_ERROR "local-global was not resumed into the band (extended: ${extended}, iterations: ${k}):\n${plain}")
endif()

# --band-cap: the same run, but the other methods may spend only a hundredth of quasi-newton's time
# to the band, which the 4-iteration reference run already passes: local-global is not resumed.
run_bench(--time-to-band --band-iterations 4 --band-extend 2000 --band-cap 0.01 --shapes bar --sizes 1000
          --no-cgal --output-dir ${WORK}/band_cap)
file(READ ${WORK}/band_cap/band.json doc)
string(JSON cap GET "${doc}" meshes 0 cpu_ms_cap)
string(JSON plain GET "${doc}" meshes 0 runs 0)
string(JSON k GET "${plain}" iterations_to_band)
string(JSON budget GET "${plain}" cpu_ms_budget)
string(JSON reference GET "${plain}" reference_cpu_ms)
if(NOT k EQUAL 0 OR NOT budget STREQUAL reference)
  message(FATAL_ERROR "local-global went on past the cap of ${cap} ms:\n${plain}")
endif()
file(READ ${WORK}/band_cap/band.md table)
if(NOT table MATCHES "\\| bar-[0-9]+ \\| [0-9]+ \\| 0 / > [0-9.]+ \\* \\| ")
  message(FATAL_ERROR "band.md does not show local-global stopped at the cap:\n${table}")
endif()

# --settle-step: every method settles the bent bar, then a further step; each row says iterations,
# the first iteration in the band, CPU ms and whether the settle landed in the band, and the warm
# settle ran at least one iteration and entered the band no later than it stopped.
run_bench(--settle-step 0.05 --settle-repeats 1 --shapes bar --sizes 1000 --output-dir ${WORK}/settle)
file(READ ${WORK}/settle/settle.md table)
if(NOT table MATCHES "\\| bar-[0-9]+ \\| [0-9]+ \\| [0-9]+ / [0-9]+ / [0-9.e+]+ / yes \\| [0-9]+( \\(cap\\))? / ([0-9]+|-) / [0-9.e+]+ / (yes|no) \\|")
  message(FATAL_ERROR "settle.md has no row for the bar:\n${table}")
endif()
file(READ ${WORK}/settle/settle.json doc)
string(JSON qn GET "${doc}" meshes 0 runs 0)
string(JSON method GET "${qn}" method)
string(JSON iterations GET "${qn}" iterations)
string(JSON in_band GET "${qn}" in_band)
string(JSON band_at GET "${qn}" band_iteration)
if(NOT method STREQUAL "quasi-newton" OR iterations LESS 1 OR NOT in_band OR band_at LESS 1 OR band_at GREATER iterations)
  message(FATAL_ERROR "quasi-newton's settle after the step is not as expected:\n${qn}")
endif()
