# FindCGNS: the CGNS mid-level library as packaged by Debian (libcgns-dev), which
# ships no CMake config. scripts/install-deps.sh installs it.
#
# Defines the imported target CGNS::CGNS.
find_path(CGNS_INCLUDE_DIR NAMES cgnslib.h)
find_library(CGNS_LIBRARY NAMES cgns)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CGNS
  REQUIRED_VARS CGNS_LIBRARY CGNS_INCLUDE_DIR
  REASON_FAILURE_MESSAGE "the CGNS library writes .cgns meshes: install libcgns-dev (scripts/install-deps.sh)")

if(CGNS_FOUND AND NOT TARGET CGNS::CGNS)
  add_library(CGNS::CGNS UNKNOWN IMPORTED)
  set_target_properties(CGNS::CGNS PROPERTIES
    IMPORTED_LOCATION "${CGNS_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CGNS_INCLUDE_DIR}")
endif()
mark_as_advanced(CGNS_INCLUDE_DIR CGNS_LIBRARY)
