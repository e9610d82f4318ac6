# Proves that raylife's Doxygen configuration rejects an undocumented public declaration (and accepts a documented
# one), so the docs check cannot silently stop checking.
#   cmake -DDOXYGEN=<doxygen> -DDOXYFILE=<raylife's Doxyfile> -DFIXTURE=<header> -DEXPECT=pass|fail -DOUT=<dir>
#         -P check_config.cmake
foreach(var DOXYGEN DOXYFILE FIXTURE EXPECT OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_config.cmake: -D${var}=... is required")
  endif()
endforeach()

# raylife's configuration, with only the input and the output moved: every warning setting is the real one.
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
file(WRITE ${OUT}/Doxyfile
  "@INCLUDE = ${DOXYFILE}\n"
  "INPUT = ${FIXTURE}\n"
  "USE_MDFILE_AS_MAINPAGE =\n"
  "OUTPUT_DIRECTORY = ${OUT}\n"
  "WARN_LOGFILE = ${OUT}/warnings.log\n"
  "HAVE_DOT = NO\n")
execute_process(COMMAND ${DOXYGEN} ${OUT}/Doxyfile RESULT_VARIABLE status OUTPUT_QUIET ERROR_QUIET)
set(log "")
if(EXISTS ${OUT}/warnings.log)
  file(READ ${OUT}/warnings.log log)
endif()

if(EXPECT STREQUAL "fail")
  if(status EQUAL 0 OR NOT log MATCHES "forgotten")
    message(FATAL_ERROR "Doxygen accepted an undocumented declaration (status ${status}):\n${log}")
  endif()
elseif(EXPECT STREQUAL "pass")
  if(NOT status EQUAL 0 OR NOT log STREQUAL "")
    message(FATAL_ERROR "Doxygen rejected a fully documented header (status ${status}):\n${log}")
  endif()
else()
  message(FATAL_ERROR "check_config.cmake: EXPECT must be pass or fail")
endif()
message(STATUS "Doxygen ${EXPECT}ed ${FIXTURE}, as it must")
