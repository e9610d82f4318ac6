# Runs gen_density (GEN) as scenes/media/cloud.json (EXPECTED) was written (N 40, seed 1) and requires the same
# bytes: the cloud is a file the project makes, so it must make it again.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${GEN} ${WORK}/cloud.json 40 1 RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "gen_density failed with status ${status}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/cloud.json ${EXPECTED} RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "gen_density ${WORK}/cloud.json 40 1 does not write ${EXPECTED} again")
endif()
