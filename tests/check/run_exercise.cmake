# Runs every chapter's exercise as generated (its idea taken out) with the command raylife_check prints for the
# chapter: it must run, and raylife_check must fail its image (exit 1) with a difference image.
# EXERCISES: a list of CHAPTER=PROGRAM.
file(REMOVE_RECURSE ${WORK})
foreach(entry IN LISTS EXERCISES)
  string(REGEX MATCH "^([^=]+)=(.*)$" matched "${entry}")
  set(chapter ${CMAKE_MATCH_1})
  set(exercise ${CMAKE_MATCH_2})
  file(MAKE_DIRECTORY ${WORK}/${chapter})
  execute_process(COMMAND ${CHECK} ${chapter} OUTPUT_VARIABLE command OUTPUT_STRIP_TRAILING_WHITESPACE
                  ERROR_QUIET)
  separate_arguments(args UNIX_COMMAND "${command}")
  list(POP_FRONT args program)
  execute_process(COMMAND ${exercise} ${args} --quiet WORKING_DIRECTORY ${WORK}/${chapter} RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "the exercise of ${chapter} does not run: ${status}")
  endif()
  execute_process(COMMAND ${CHECK} ${chapter} ${chapter}.pfm WORKING_DIRECTORY ${WORK}/${chapter}
                  RESULT_VARIABLE status OUTPUT_VARIABLE out)
  string(REGEX MATCH "^[^\n]*" verdict "${out}")
  message(STATUS "${verdict}")
  if(NOT status EQUAL 1 OR NOT EXISTS ${WORK}/${chapter}/${chapter}-difference.png)
    message(FATAL_ERROR "raylife_check did not fail the unfinished exercise of ${chapter} (status ${status})")
  endif()
endforeach()
list(LENGTH EXERCISES count)
if(count LESS 10)
  message(FATAL_ERROR "only ${count} exercises")
endif()
