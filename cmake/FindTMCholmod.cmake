# Finds CHOLMOD from Debian's libsuitesparse-dev (5.x ships no CMake config or .pc file).
# Defines an imported target TM::Cholmod for Eigen's CholmodSupport.
find_path(TMCholmod_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(TMCholmod_LIBRARY NAMES cholmod)
find_library(TMCholmod_CONFIG_LIBRARY NAMES suitesparseconfig)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(TMCholmod
  REQUIRED_VARS TMCholmod_INCLUDE_DIR TMCholmod_LIBRARY TMCholmod_CONFIG_LIBRARY
  REASON_FAILURE_MESSAGE "install libsuitesparse-dev and libopenblas-dev (scripts/setup.sh does this)")
if(TMCholmod_FOUND AND NOT TARGET TM::Cholmod)
  add_library(TM::Cholmod INTERFACE IMPORTED)
  set_target_properties(TM::Cholmod PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${TMCholmod_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${TMCholmod_LIBRARY};${TMCholmod_CONFIG_LIBRARY}")
endif()
