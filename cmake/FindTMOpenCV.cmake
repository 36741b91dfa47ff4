# Finds the OpenCV modules from Debian's split packages (libopencv-<module>-dev; the contrib modules come
# in libopencv-contrib-dev), which ship headers and libraries but no OpenCVConfig.cmake or opencv4.pc.
# Defines an imported target TM::OpenCV carrying every requested component.
find_path(TMOpenCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
set(_tm_cv_libs)
set(_tm_cv_missing)
foreach(_c IN LISTS TMOpenCV_FIND_COMPONENTS)
  find_library(TMOpenCV_${_c}_LIBRARY NAMES opencv_${_c})
  if(TMOpenCV_${_c}_LIBRARY)
    list(APPEND _tm_cv_libs ${TMOpenCV_${_c}_LIBRARY})
    set(TMOpenCV_${_c}_FOUND TRUE)
  else()
    list(APPEND _tm_cv_missing ${_c})
  endif()
endforeach()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(TMOpenCV
  REQUIRED_VARS TMOpenCV_INCLUDE_DIR
  HANDLE_COMPONENTS
  REASON_FAILURE_MESSAGE "install libopencv-<module>-dev for: ${_tm_cv_missing} (scripts/setup.sh does this)")
if(TMOpenCV_FOUND AND NOT TARGET TM::OpenCV)
  add_library(TM::OpenCV INTERFACE IMPORTED)
  set_target_properties(TM::OpenCV PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${TMOpenCV_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_tm_cv_libs}")
endif()
