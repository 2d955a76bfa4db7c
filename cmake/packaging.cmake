# Debian packages with CPack (`cpack -G DEB` in the build folder; docs/PACKAGING.md): kiln-daemon (kilnd, kiln-brdf,
# kiln-sky, the OpenColorIO config, /etc/kiln/kilnd.conf, the systemd unit, the kiln user, the store /var/lib/kiln and
# a token made at install), kiln-client (kiln, the Python module, the wheel, the example jobs) and libkiln-client-dev
# (the static C++ client, its headers, CMake and pkg-config files). The components are cmake/install.cmake's.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME kiln)
set(CPACK_PACKAGE_VENDOR kiln)
# Whoever builds the packages for a studio names themselves here (lintian refuses a localhost address).
set(KILN_DEB_MAINTAINER "kiln maintainers <maintainers@kiln.example>" CACHE STRING "Maintainer of the Debian packages")
set(CPACK_PACKAGE_CONTACT "${KILN_DEB_MAINTAINER}")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "offline baking service for asset pipelines")
# /usr, installed through DESTDIR: cmake/install_system_files.cmake sees the real prefix and puts the system files
# under /etc, /lib/systemd/system in the package, not under the staging folder's path.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL daemon client dev)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
if(NOT CPACK_DEBIAN_PACKAGE_RELEASE)
  set(CPACK_DEBIAN_PACKAGE_RELEASE 1)
endif()
set(CPACK_DEBIAN_PACKAGE_SECTION graphics)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
# Library dependencies computed from the binaries with dpkg-shlibdeps.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)

set(CPACK_DEBIAN_DAEMON_PACKAGE_NAME kiln-daemon)
set(CPACK_DEBIAN_DAEMON_PACKAGE_SECTION net)
set(CPACK_DEBIAN_DAEMON_PACKAGE_DEPENDS "adduser, init-system-helpers (>= 1.54~)")
set(CPACK_COMPONENT_DAEMON_DESCRIPTION "offline baking service for asset pipelines: the daemon
 kilnd takes bake jobs (lightmaps, environment maps, materials and BRDF tables)
 over a socket as protobuf messages, ray-traces them on the CPU and returns the
 baked textures with a report of what they cost. This package runs it as the
 systemd service kilnd: user kiln, store /var/lib/kiln, configuration
 /etc/kiln/kilnd.conf, a token generated into /etc/kiln/tokens at install.
 With the local tools kiln-brdf and kiln-sky.")
# dpkg knows the maintainer scripts by their file names: postinst, prerm, postrm, conffiles.
set(_kiln_maint ${PROJECT_SOURCE_DIR}/deploy/debian/kiln-daemon)
set(CPACK_DEBIAN_DAEMON_PACKAGE_CONTROL_EXTRA
    ${_kiln_maint}/postinst ${_kiln_maint}/prerm ${_kiln_maint}/postrm ${_kiln_maint}/conffiles)
set(CPACK_DEBIAN_DAEMON_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)

set(CPACK_DEBIAN_CLIENT_PACKAGE_NAME kiln-client)
set(CPACK_DEBIAN_CLIENT_PACKAGE_DEPENDS "python3, python3-protobuf (>= 3.20)")
set(CPACK_COMPONENT_CLIENT_DESCRIPTION "offline baking service for asset pipelines: the clients
 kiln submits bake jobs to kilnd, follows them and fetches their outputs; the
 Python module kiln (python3 -m kiln) does the same from pipelines. Also the
 example jobs, and the Python client as a wheel for other interpreters.")

set(CPACK_DEBIAN_DEV_PACKAGE_NAME libkiln-client-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "libprotobuf-dev, libssl-dev, libboost-system-dev")
set(CPACK_COMPONENT_DEV_DESCRIPTION "offline baking service for asset pipelines: the C++ client library
 A static library with its headers to talk to kilnd from C++:
 find_package(kiln) gives the CMake target kiln::client; pkg-config kiln-client
 gives the flags.")

include(CPack)
