# Run by `cmake --install` (install(CODE) in cmake/install.cmake): installs kilnd.conf and kilnd.service with the
# paths of the prefix given at install time. With the /usr prefix (the Debian packages) they are the system's:
# /etc/kiln, /var/lib/kiln, /run/kiln, /lib/systemd/system; with any other prefix P they stay under it: P/etc/kiln,
# P/var/lib/kiln, P/run/kiln, P/lib/systemd/system, so that an install to a scratch prefix runs as it is.
# In: KILN_SOURCE_DIR, KILN_BINARY_DIR, KILN_BINDIR (relative to the prefix), CMAKE_INSTALL_PREFIX. DESTDIR is
# honoured by file(INSTALL).
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(_root "")
  # Where Debian 12's packages put units (lintian: systemd-service-file-outside-lib).
  set(_unit_dir "/lib/systemd/system")
else()
  set(_root "${CMAKE_INSTALL_PREFIX}")
  set(_unit_dir "${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
endif()
set(_etc "${_root}/etc/kiln")
set(_store "${_root}/var/lib/kiln")
set(_run "${_root}/run/kiln")
set(_bin "${CMAKE_INSTALL_PREFIX}/${KILN_BINDIR}")
set(_staging "${KILN_BINARY_DIR}/kiln-install-staging")
file(MAKE_DIRECTORY "${_staging}")

file(READ "${KILN_SOURCE_DIR}/deploy/kilnd.conf" _conf)
string(REPLACE "\"/var/lib/kiln\"" "\"${_store}\"" _conf "${_conf}")
string(REPLACE "\"/etc/kiln/" "\"${_etc}/" _conf "${_conf}")
string(REPLACE "\"/run/kiln/" "\"${_run}/" _conf "${_conf}")
file(WRITE "${_staging}/kilnd.conf" "${_conf}")

file(READ "${KILN_SOURCE_DIR}/deploy/kilnd.service" _unit)
string(REPLACE "/usr/local/bin/kilnd" "${_bin}/kilnd" _unit "${_unit}")
string(REPLACE "/etc/kiln/kilnd.conf" "${_etc}/kilnd.conf" _unit "${_unit}")
if(NOT _root STREQUAL "")
  # ProtectSystem=strict leaves only /var/lib/kiln (StateDirectory) writable: open the prefix's store too.
  string(REPLACE "StateDirectory=kiln" "StateDirectory=kiln\nReadWritePaths=${_store}" _unit "${_unit}")
endif()
file(WRITE "${_staging}/kilnd.service" "${_unit}")

# An edited kilnd.conf is the administrator's: a second install leaves it and puts the new one beside it.
if(EXISTS "$ENV{DESTDIR}${_etc}/kilnd.conf")
  file(READ "$ENV{DESTDIR}${_etc}/kilnd.conf" _installed)
  if(NOT _installed STREQUAL _conf)
    message(STATUS "Keeping the edited $ENV{DESTDIR}${_etc}/kilnd.conf; the new one is kilnd.conf.new beside it")
    file(RENAME "${_staging}/kilnd.conf" "${_staging}/kilnd.conf.new")
  endif()
endif()
file(GLOB _confs "${_staging}/kilnd.conf*")
file(INSTALL DESTINATION "${_etc}" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ FILES ${_confs})
file(INSTALL DESTINATION "${_unit_dir}" TYPE FILE PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ
     FILES "${_staging}/kilnd.service")
file(REMOVE_RECURSE "${_staging}")
# The store: under a scratch prefix it is made here; the Debian package makes /var/lib/kiln, owned by kiln, itself.
if(NOT _root STREQUAL "")
  file(MAKE_DIRECTORY "$ENV{DESTDIR}${_store}")
endif()
