# Runs gen_density (GEN) as EXPECTED was written (ARGS: its arguments after the output file) and requires the same
# bytes: the clouds in scenes/media are files the project makes, so it must make them again.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${GEN} ${WORK}/cloud.json ${ARGS} RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "gen_density ${WORK}/cloud.json ${ARGS} failed with status ${status}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/cloud.json ${EXPECTED} RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "gen_density ${WORK}/cloud.json ${ARGS} does not write ${EXPECTED} again")
endif()
