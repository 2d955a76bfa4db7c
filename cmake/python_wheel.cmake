# The Python client as a wheel, <build>/python/dist/kiln_client-VERSION-py3-none-any.whl, carrying the kiln_pb2.py
# this build generated: for the Pythons of pipelines' tools (Houdini, Maya, Blender, CI runners) on machines without
# protoc. Built by Debian's /usr/bin/python3 with its pip, setuptools and wheel (deploy/setup.sh installs them).
file(STRINGS ${PROJECT_SOURCE_DIR}/client/python/pyproject.toml _kiln_py_version REGEX "^version = ")
if(NOT _kiln_py_version STREQUAL "version = \"${PROJECT_VERSION}\"")
  message(FATAL_ERROR "client/python/pyproject.toml says ${_kiln_py_version}; the project is ${PROJECT_VERSION}: "
                      "give both the same version")
endif()

execute_process(COMMAND /usr/bin/python3 -c "import setuptools, wheel, pip" RESULT_VARIABLE _kiln_py_tools
                OUTPUT_QUIET ERROR_QUIET)
if(NOT _kiln_py_tools EQUAL 0)
  message(STATUS "kiln: /usr/bin/python3 lacks pip, setuptools or wheel (Debian: python3-pip python3-setuptools "
                 "python3-wheel): no Python wheel")
  return()
endif()

set(_stage ${PROJECT_BINARY_DIR}/python/package)
set(KILN_PYTHON_WHEEL ${PROJECT_BINARY_DIR}/python/dist/kiln_client-${PROJECT_VERSION}-py3-none-any.whl)
file(GLOB _kiln_py_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/client/python/kiln/*.py)
set(_kiln_py_files ${PROJECT_SOURCE_DIR}/client/python/pyproject.toml ${PROJECT_SOURCE_DIR}/client/python/setup.py
                   ${PROJECT_SOURCE_DIR}/client/python/README.md)
add_custom_command(OUTPUT ${KILN_PYTHON_WHEEL}
  COMMAND ${CMAKE_COMMAND} -E rm -rf ${_stage} ${PROJECT_BINARY_DIR}/python/dist
  COMMAND ${CMAKE_COMMAND} -E make_directory ${_stage}/kiln
  COMMAND ${CMAKE_COMMAND} -E copy ${_kiln_py_files} ${_stage}
  COMMAND ${CMAKE_COMMAND} -E copy ${_kiln_py_sources} ${PROJECT_BINARY_DIR}/python/kiln/kiln_pb2.py ${_stage}/kiln
  COMMAND ${CMAKE_COMMAND} -E env --unset=PIP_FIND_LINKS --unset=PIP_INDEX_URL
          /usr/bin/python3 -m pip wheel --quiet --disable-pip-version-check --no-build-isolation --no-index --no-deps
          --wheel-dir ${PROJECT_BINARY_DIR}/python/dist ${_stage}
  DEPENDS ${_kiln_py_files} ${_kiln_py_sources} ${PROJECT_BINARY_DIR}/python/kiln/kiln_pb2.py
  COMMENT "Building the Python client's wheel" VERBATIM)
add_custom_target(kiln_python_wheel ALL DEPENDS ${KILN_PYTHON_WHEEL})
# Made in proto/ (kiln_proto_python): an order dependency here, the file dependency above for rebuilds.
add_dependencies(kiln_python_wheel kiln_proto_python)
