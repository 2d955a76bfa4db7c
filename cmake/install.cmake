# What `cmake --install build --prefix P` puts where (also what cpack packs; cmake/packaging.cmake). Components:
# daemon (kilnd, the local tools, the OpenColorIO config, kilnd.conf, the systemd unit), client (kiln, the Python
# module, the example jobs) and dev (the C++ client library, its headers, CMake package config and pkg-config file).
# The binaries carry no path to the source or build tree: the OCIO config is compiled in (bakers/CMakeLists.txt) and
# installed only for $OCIO users; the paths in kilnd.conf and the unit follow the prefix
# (cmake/install_system_files.cmake).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# --- programs ------------------------------------------------------------------------------------------------
install(TARGETS kilnd kiln-brdf kiln-sky RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT daemon)
install(TARGETS kiln RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT client)

# --- data ------------------------------------------------------------------------------------------------------
install(FILES ${PROJECT_SOURCE_DIR}/deploy/ocio/config.ocio DESTINATION ${CMAKE_INSTALL_DATADIR}/kiln/ocio
        COMPONENT daemon)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/client/examples/ DESTINATION ${CMAKE_INSTALL_DATADIR}/kiln/examples
        COMPONENT client FILES_MATCHING PATTERN "*.textproto" PATTERN "*.py")
# kilnd.conf and the unit name paths that depend on the prefix given at install time, not at configure time.
install(CODE "set(KILN_SOURCE_DIR \"${PROJECT_SOURCE_DIR}\")
set(KILN_BINARY_DIR \"${PROJECT_BINARY_DIR}\")
set(KILN_BINDIR \"${CMAKE_INSTALL_BINDIR}\")
include(\"${PROJECT_SOURCE_DIR}/cmake/install_system_files.cmake\")" COMPONENT daemon)

# --- the Python module (the pip route: client/python/pyproject.toml) ----------------------------------------------
# Debian's layout by default (/usr/lib/python3/dist-packages with the /usr prefix); set it to your interpreter's
# site-packages relative to the prefix for another one.
set(KILN_INSTALL_PYTHONDIR "lib/python3/dist-packages" CACHE STRING
    "Where the Python module kiln goes, under the prefix")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/client/python/kiln DESTINATION ${KILN_INSTALL_PYTHONDIR} COMPONENT client
        FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
install(FILES ${PROJECT_BINARY_DIR}/python/kiln/kiln_pb2.py DESTINATION ${KILN_INSTALL_PYTHONDIR}/kiln COMPONENT client)
# The wheel (cmake/python_wheel.cmake), for `pip install` into the Pythons of pipelines' tools.
if(KILN_PYTHON_WHEEL)
  install(FILES ${KILN_PYTHON_WHEEL} DESTINATION ${CMAKE_INSTALL_DATADIR}/kiln/python COMPONENT client)
endif()

# --- the C++ client library: find_package(kiln) gives kiln::client; pkg-config kiln-client ---------------------------
install(TARGETS kiln_client kiln_proto kiln_digest EXPORT kilnTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
# --strip (and CPack's CPACK_STRIP_FILES) leave static libraries alone; their debug info is 9/10 of their size
# (libkiln_proto.a: 10.1 MB, 0.95 MB without).
if(CMAKE_STRIP)
  install(CODE "if(CMAKE_INSTALL_DO_STRIP)
  foreach(lib kiln_client kiln_proto kiln_digest)
    execute_process(COMMAND \"${CMAKE_STRIP}\" --strip-debug
                            \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}/lib\${lib}.a\"
                    COMMAND_ERROR_IS_FATAL ANY)
  endforeach()
endif()" COMPONENT dev)
endif()
install(FILES ${PROJECT_SOURCE_DIR}/client/lib/client.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kiln/client/lib
        COMPONENT dev)
install(FILES ${PROJECT_BINARY_DIR}/proto/kiln.pb.h ${PROJECT_SOURCE_DIR}/proto/kiln.proto
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/kiln/proto COMPONENT dev)
set(KILN_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/kiln)
install(EXPORT kilnTargets NAMESPACE kiln:: DESTINATION ${KILN_CMAKEDIR} COMPONENT dev)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/kilnConfig.cmake.in ${PROJECT_BINARY_DIR}/kilnConfig.cmake
                              INSTALL_DESTINATION ${KILN_CMAKEDIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/kilnConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/kilnConfig.cmake ${PROJECT_BINARY_DIR}/kilnConfigVersion.cmake
        DESTINATION ${KILN_CMAKEDIR} COMPONENT dev)
# The .pc file finds its prefix from its own place (${pcfiledir}), so it stays right under any --prefix.
file(RELATIVE_PATH KILN_PC_TO_PREFIX /${CMAKE_INSTALL_LIBDIR}/pkgconfig /)
string(REGEX REPLACE "/$" "" KILN_PC_TO_PREFIX "${KILN_PC_TO_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/kiln-client.pc.in ${PROJECT_BINARY_DIR}/kiln-client.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/kiln-client.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)

# --- man pages, from each program's --help (help2man, Debian's package of that name) ---------------------------------
find_program(KILN_HELP2MAN help2man)
if(KILN_HELP2MAN)
  set(_man_pages "")
  foreach(pair "kilnd:daemon:the kiln baking daemon" "kiln:client:submit bake jobs to kilnd and fetch their outputs"
               "kiln-brdf:daemon:evaluate and tabulate kiln's BRDF models"
               "kiln-sky:daemon:write a synthetic HDR sky for environment bakes")
    string(REPLACE ":" ";" fields "${pair}")
    list(GET fields 0 program)
    list(GET fields 1 component)
    list(GET fields 2 summary)
    set(page ${PROJECT_BINARY_DIR}/man/${program}.1)
    # --version-string: not every program has --version; --no-info: Debian has no info pages for these. Compressed
    # as Debian policy 12.1 asks (gzip -9n: reproducible).
    add_custom_command(OUTPUT ${page}.gz
      COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/man
      COMMAND ${KILN_HELP2MAN} --no-info --no-discard-stderr --version-string=${PROJECT_VERSION}
              --name=${summary} --section=1 --output=${page} $<TARGET_FILE:${program}>
      COMMAND gzip -9nf ${page}
      DEPENDS ${program} VERBATIM)
    set(page ${page}.gz)
    list(APPEND _man_pages ${page})
    install(FILES ${page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT ${component})
  endforeach()
  add_custom_target(kiln_man_pages ALL DEPENDS ${_man_pages})
else()
  message(STATUS "kiln: help2man not found (Debian package help2man): installing without man pages")
endif()

# --- each package's documentation folder: copyright and changelog (Debian policy 12.5, 12.7) ---------------------
execute_process(COMMAND gzip -9nc ${PROJECT_SOURCE_DIR}/deploy/debian/changelog
                OUTPUT_FILE ${PROJECT_BINARY_DIR}/changelog.Debian.gz COMMAND_ERROR_IS_FATAL ANY)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/deploy/debian/changelog)
foreach(component daemon client dev)
  set(_package "kiln-${component}")
  if(component STREQUAL "dev")
    set(_package "libkiln-client-dev")
  endif()
  install(FILES ${PROJECT_SOURCE_DIR}/deploy/debian/copyright ${PROJECT_BINARY_DIR}/changelog.Debian.gz
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${_package} COMPONENT ${component})
endforeach()
