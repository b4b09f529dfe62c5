# Compiles every source of coordinator/ (main.cpp and the sources of core/, store/, rpc/ and web/)
# with Clang's thread-safety analysis (-Wthread-safety), from the build's own compile commands
# (compile_commands.json: the same flags and include paths), syntax only, every other warning off. Fails on the first source whose locking breaks its
# annotations (coordinator/core/locking.h). Run by CTest as ThreadSafety.CoordinatorLockingIsCheckedByClang:
#   cmake -DCLANG=clang++ -DCOMMANDS=build/compile_commands.json -DSOURCES=<root>/coordinator -P thread_safety.cmake
file(READ "${COMMANDS}" commands)
string(JSON count LENGTH "${commands}")
math(EXPR last "${count} - 1")
set(checked 0)
foreach(i RANGE ${last})
  string(JSON file GET "${commands}" ${i} file)
  if(NOT file MATCHES "^${SOURCES}/(.+/)?[^/]+\\.cpp$")  # main.cpp and core/, store/, rpc/, web/
    continue()
  endif()
  string(JSON directory GET "${commands}" ${i} directory)
  string(JSON command GET "${commands}" ${i} command)
  separate_arguments(args UNIX_COMMAND "${command}")
  list(POP_FRONT args)  # the compiler
  # Drop the output (-o FILE) and the dependency file flags; compile nothing, only analyse.
  set(kept "")
  set(skip FALSE)
  foreach(a ${args})
    if(skip)
      set(skip FALSE)
    elseif(a STREQUAL "-o" OR a STREQUAL "-MF" OR a STREQUAL "-MT")
      set(skip TRUE)
    elseif(NOT a STREQUAL "-MD" AND NOT a STREQUAL "-c")
      list(APPEND kept "${a}")
    endif()
  endforeach()
  execute_process(COMMAND ${CLANG} ${kept} -fsyntax-only -Wno-everything -Wthread-safety -Werror=thread-safety
                  WORKING_DIRECTORY "${directory}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${file}: Clang's thread-safety analysis fails:\n${err}${out}")
  endif()
  math(EXPR checked "${checked} + 1")
endforeach()
if(checked LESS 10)
  message(FATAL_ERROR "only ${checked} sources of ${SOURCES} in ${COMMANDS}")
endif()
message(STATUS "${checked} sources of ${SOURCES}: the locking keeps its annotations")
