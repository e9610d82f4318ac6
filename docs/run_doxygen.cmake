# Runs Doxygen and fails on any warning, printing each one and their count.
#   cmake -DDOXYGEN=<doxygen> -DDOXYFILE=<Doxyfile> -DWARNINGS=<log> -DSITE=<html dir>
#         -DUSAGE_COMMAND=<chapter binary> -DGENERATED=<dir> -P run_doxygen.cmake
# First it captures `<chapter binary> --help` into GENERATED/usage.txt, which the command-line page includes, so
# that page shows the program's own help text.
# The Doxyfile sends warnings to WARNINGS (WARN_LOGFILE) and sets WARN_AS_ERROR = FAIL_ON_WARNINGS, so Doxygen
# itself also exits non-zero on a warning; counting them here gives the one line the build log needs.
foreach(var DOXYGEN DOXYFILE WARNINGS SITE USAGE_COMMAND GENERATED)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_doxygen.cmake: -D${var}=... is required")
  endif()
endforeach()

file(MAKE_DIRECTORY ${GENERATED})
execute_process(COMMAND ${USAGE_COMMAND} --help OUTPUT_FILE ${GENERATED}/usage.txt RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "raylife docs: '${USAGE_COMMAND} --help' failed (status ${status})")
endif()

file(REMOVE ${WARNINGS})
execute_process(COMMAND ${DOXYGEN} ${DOXYFILE} RESULT_VARIABLE status)

set(count 0)
if(EXISTS ${WARNINGS})
  file(STRINGS ${WARNINGS} lines)
  foreach(line IN LISTS lines)
    if(line MATCHES "(warning|error): ")
      math(EXPR count "${count} + 1")
    endif()
  endforeach()
  if(count GREATER 0)
    file(READ ${WARNINGS} text)
    message("${text}")
  endif()
endif()

if(NOT status EQUAL 0 OR count GREATER 0)
  message(FATAL_ERROR "raylife docs: ${count} Doxygen warning(s) (exit status ${status}); every public declaration in "
                      "common/ needs a Doxygen comment, and every \\snippet and \\image must be found. See above.")
endif()
message(STATUS "raylife docs: 0 Doxygen warnings. Open ${SITE}/index.html")
