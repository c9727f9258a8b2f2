# Repairs include directories exported by ROS 2 Python wheels.
#
# The wheels' `*__rosidl_generator_pyExport.cmake` files hard-code the include directories of
# the interpreter that built them (/opt/python/cp311-cp311/...). CMake rejects an imported
# target whose INTERFACE_INCLUDE_DIRECTORIES names a path that does not exist. At the end of
# configure (deferred, so every imported target exists), this replaces such paths with the
# Python and NumPy include directories of the interpreter found here.

function(_pd_fix_wheel_python_includes)
  find_package(Python3 REQUIRED COMPONENTS Interpreter Development.Module NumPy)
  get_property(_targets DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(_target IN LISTS _targets)
    get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT _dirs)
      continue()
    endif()
    set(_fixed "")
    set(_changed FALSE)
    foreach(_dir IN LISTS _dirs)
      if(_dir MATCHES "^/opt/python/" AND NOT EXISTS "${_dir}")
        set(_changed TRUE)
        if(_dir MATCHES "numpy")
          list(APPEND _fixed ${Python3_NumPy_INCLUDE_DIRS})
        else()
          list(APPEND _fixed ${Python3_INCLUDE_DIRS})
        endif()
      else()
        list(APPEND _fixed "${_dir}")
      endif()
    endforeach()
    if(_changed)
      list(REMOVE_DUPLICATES _fixed)
      set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_fixed}")
    endif()
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" CALL _pd_fix_wheel_python_includes)
