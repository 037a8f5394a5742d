# ROS 2 wheels from PyPI export the Python include paths of the machine they were built on
# (/opt/python/...), which makes generation fail with "includes non-existent path". Point every
# imported *__rosidl_generator_py target at this machine's Python and NumPy headers instead.
# On a normal ROS install the paths exist and this changes nothing that matters.
find_package(Python3 REQUIRED COMPONENTS Interpreter Development NumPy)
get_directory_property(imported_targets IMPORTED_TARGETS)
foreach(target IN LISTS imported_targets)
  if(target MATCHES "__rosidl_generator_py$")
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    set(fixed "")
    foreach(dir IN LISTS dirs)
      if(EXISTS "${dir}")
        list(APPEND fixed "${dir}")
      endif()
    endforeach()
    list(APPEND fixed ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
    set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${fixed}")
  endif()
endforeach()
