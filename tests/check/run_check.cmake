# One chapter through raylife_check as a student runs it: the command `raylife_check NAME` prints, with another
# SEED and THREADS, must pass as PFM and as PNG; so must the chapter's default render (its default size).
# For a Monte Carlo chapter the samples per pixel the command states must be the chapter's default (read back from
# the default render's --stats file), the figure raylife_check assumes when it is not told.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${CHECK} ${NAME} OUTPUT_VARIABLE command ERROR_VARIABLE explanation RESULT_VARIABLE status
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "raylife_check ${NAME} failed (${status}): ${explanation}\n"
          "A new chapter needs its line in tools/check/chapters.h and its golden (tools/update_goldens.sh).")
endif()
separate_arguments(args UNIX_COMMAND "${command}")
list(POP_FRONT args program)
message(STATUS "command: ${command}")

function(run_in_work)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK} RESULT_VARIABLE status OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "failed (${status}): ${ARGN}\n${out}${err}")
  endif()
  message(STATUS "${out}")
endfunction()

run_in_work(${CHAPTER} ${args} --seed ${SEED} --threads ${THREADS} --quiet -o ${NAME}.png)
run_in_work(${CHECK} ${NAME} ${NAME}.pfm)
run_in_work(${CHECK} ${NAME} ${NAME}.png)

# The default render (what `cmake --workflow --preset render` writes into out/): at its default size, graded as
# it is. A Monte Carlo chapter renders it with 8 spp (told by its --stats file), which at the default size
# (4 or 5 times the reference's in each direction) is as many samples per reference pixel as its default, at a
# sixteenth of the time.
if(NOT command MATCHES "--spp ([0-9]+)")
  run_in_work(${CHAPTER} --seed ${SEED} --threads ${THREADS} --quiet -o default.png)
  run_in_work(${CHECK} ${NAME} default.png)
  return()
endif()
run_in_work(${CHAPTER} --seed ${SEED} --threads ${THREADS} --spp 8 --quiet -o default.png -o default.pfm
            --stats default.json)
run_in_work(${CHECK} ${NAME} default.pfm)
run_in_work(${CHECK} ${NAME} default.png --spp 8)
# The samples per pixel the command states must be the chapter's default, which raylife_check assumes when not told.
set(stated ${CMAKE_MATCH_1})
run_in_work(${CHAPTER} --width 4 --height 3 --quiet -o tiny.pfm --stats tiny.json)
file(READ ${WORK}/tiny.json stats)
string(JSON spp GET "${stats}" spp)
if(NOT spp EQUAL stated)
  message(FATAL_ERROR "raylife_check states ${stated} spp for ${NAME}, but its default is ${spp}: "
          "fix the chapter's line in tools/check/chapters.h")
endif()
