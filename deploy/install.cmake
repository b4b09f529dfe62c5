# Run by `cmake --install` (see the top CMakeLists.txt), when the install prefix is known, so
# that the systemd units name the binaries and the configuration where they were installed:
#   <prefix>/lib/systemd/system/lensfarm-coordinator.service, lensfarm-worker@.service
#   <sysconfdir>/lensfarm/coordinator.env, worker.env   (examples; an existing file is kept)
# <sysconfdir> is /etc for the prefix /usr, else <prefix>/etc (as GNUInstallDirs has it).
# Expects LENSFARM_SOURCE_DIR, LENSFARM_INSTALL_BINDIR and LENSFARM_INSTALL_DOCDIR (the last two
# relative to the prefix).
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(LENSFARM_CONFDIR "/etc/lensfarm")
else()
  set(LENSFARM_CONFDIR "${CMAKE_INSTALL_PREFIX}/etc/lensfarm")
endif()
set(LENSFARM_BINDIR "${CMAKE_INSTALL_PREFIX}/${LENSFARM_INSTALL_BINDIR}")
set(LENSFARM_DOCDIR "${CMAKE_INSTALL_PREFIX}/${LENSFARM_INSTALL_DOCDIR}")

set(unitDir "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
foreach(unit lensfarm-coordinator.service lensfarm-worker@.service)
  message(STATUS "Installing: ${unitDir}/${unit}")
  configure_file("${LENSFARM_SOURCE_DIR}/deploy/systemd/${unit}.in" "${unitDir}/${unit}" @ONLY)
  list(APPEND CMAKE_INSTALL_MANIFEST_FILES "${CMAKE_INSTALL_PREFIX}/lib/systemd/system/${unit}")
endforeach()

foreach(example coordinator.env worker.env)
  if(EXISTS "$ENV{DESTDIR}${LENSFARM_CONFDIR}/${example}")
    message(STATUS "Keeping: $ENV{DESTDIR}${LENSFARM_CONFDIR}/${example}")
  else()
    file(INSTALL "${LENSFARM_SOURCE_DIR}/deploy/systemd/${example}" DESTINATION "${LENSFARM_CONFDIR}")
  endif()
endforeach()
