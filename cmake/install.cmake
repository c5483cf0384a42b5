# Install rules (included by the top-level CMakeLists.txt when PGI_INSTALL is ON):
#   lib/libphotongi.a (or .so), include/photongi/*.h (version.h included), bin/photongi
#   (and photongi-view), lib/cmake/photongi/ (find_package(photongi) -> photongi::photongi),
#   lib/pkgconfig/photongi.pc, share/doc/photongi/{LICENSE,README.md,CHANGELOG.md,docs/},
#   share/photongi/scenes/*.json.
include(CMakePackageConfigHelpers)

if(PGI_LIBRARY_TYPE STREQUAL "SHARED_LIBRARY")
  set(PGI_SHARED ON)
else()
  set(PGI_SHARED OFF)
endif()

install(TARGETS photongi EXPORT photongiTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/photongi ${PROJECT_BINARY_DIR}/include/photongi
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")

# Tools: next to a shared libphotongi they find it through a relative RPATH.
set(PGI_TOOLS)
foreach(t photongi-cli photongi-view photongi-mpi)
  if(TARGET ${t})
    list(APPEND PGI_TOOLS ${t})
  endif()
endforeach()
if(PGI_TOOLS)
  if(PGI_SHARED AND NOT APPLE)
    file(RELATIVE_PATH _pgi_bin_to_lib ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
    set_target_properties(${PGI_TOOLS} PROPERTIES INSTALL_RPATH "$ORIGIN/${_pgi_bin_to_lib}")
  endif()
  install(TARGETS ${PGI_TOOLS} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

# The Python package (docs/python.md): python3 finds it in the prefix's dist-packages.
if(TARGET photongi-python)
  if(PGI_SHARED AND NOT APPLE)
    file(RELATIVE_PATH _pgi_py_to_lib ${CMAKE_INSTALL_PREFIX}/${PGI_PYTHON_INSTALL_DIR}/photongi
         ${CMAKE_INSTALL_FULL_LIBDIR})
    set_target_properties(photongi-python PROPERTIES INSTALL_RPATH "$ORIGIN/${_pgi_py_to_lib}")
  endif()
  install(TARGETS photongi-python LIBRARY DESTINATION ${PGI_PYTHON_INSTALL_DIR}/photongi)
  install(FILES ${PROJECT_SOURCE_DIR}/python/photongi/__init__.py DESTINATION ${PGI_PYTHON_INSTALL_DIR}/photongi)
endif()

# CMake package.
set(PGI_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/photongi)
install(EXPORT photongiTargets NAMESPACE photongi:: DESTINATION ${PGI_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/photongiConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/photongiConfig.cmake INSTALL_DESTINATION ${PGI_CMAKE_DIR})
# 0.x: a minor version may break the API, so 0.1 is compatible with 0.1.z only; from 1.0 on,
# any later version of the same major.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(_pgi_compat SameMinorVersion)
else()
  set(_pgi_compat SameMajorVersion)
endif()
write_basic_package_version_file(${PROJECT_BINARY_DIR}/photongiConfigVersion.cmake COMPATIBILITY ${_pgi_compat})
install(FILES ${PROJECT_BINARY_DIR}/photongiConfig.cmake ${PROJECT_BINARY_DIR}/photongiConfigVersion.cmake
        DESTINATION ${PGI_CMAKE_DIR})

# pkg-config. The prefix is taken relative to the .pc file (${pcfiledir}), so that
# `cmake --install build --prefix DIR` works whatever CMAKE_INSTALL_PREFIX was.
set(_pgi_pcdir ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}" OR IS_ABSOLUTE "${CMAKE_INSTALL_INCLUDEDIR}")
  set(PGI_PC_PREFIX "${CMAKE_INSTALL_PREFIX}")
  set(PGI_PC_LIBDIR "${CMAKE_INSTALL_FULL_LIBDIR}")
  set(PGI_PC_INCLUDEDIR "${CMAKE_INSTALL_FULL_INCLUDEDIR}")
else()
  file(RELATIVE_PATH _pgi_pc_to_prefix /prefix/${_pgi_pcdir} /prefix)
  string(REGEX REPLACE "/$" "" _pgi_pc_to_prefix "${_pgi_pc_to_prefix}")
  set(PGI_PC_PREFIX "\${pcfiledir}/${_pgi_pc_to_prefix}")
  set(PGI_PC_LIBDIR "\${prefix}/${CMAKE_INSTALL_LIBDIR}")
  set(PGI_PC_INCLUDEDIR "\${prefix}/${CMAKE_INSTALL_INCLUDEDIR}")
endif()

# Embree 3 ships no .pc file: link it by name, with its folder unless the linker searches it anyway.
set(_pgi_embree_lib)
foreach(_c "" _RELEASE _RELWITHDEBINFO _NONE _NOCONFIG _DEBUG)
  get_target_property(_loc embree IMPORTED_LOCATION${_c})
  if(_loc)
    set(_pgi_embree_lib ${_loc})
    break()
  endif()
endforeach()
set(_pgi_embree_flags -lembree3)
if(_pgi_embree_lib)
  get_filename_component(_dir ${_pgi_embree_lib} DIRECTORY)
  get_filename_component(_name ${_pgi_embree_lib} NAME)
  string(REGEX REPLACE "^lib([^.]+)\\..*$" "\\1" _name ${_name})
  set(_pgi_embree_flags -l${_name})
  list(FIND CMAKE_C_IMPLICIT_LINK_DIRECTORIES ${_dir} _implicit)
  if(_implicit LESS 0)
    set(_pgi_embree_flags -L${_dir} ${_pgi_embree_flags})
  endif()
endif()
string(REPLACE ";" " " _pgi_embree_flags "${_pgi_embree_flags}")

set(_pgi_pc_modules "assimp OpenEXR libcjson stb")
if(PGI_VULKAN)
  string(APPEND _pgi_pc_modules " vulkan")
endif()
set(_pgi_pc_libs "${_pgi_embree_flags} ${OpenMP_C_FLAGS} -lm")
if(PGI_SHARED)
  # libphotongi.so records its own dependencies: the consumer links -lphotongi alone
  # (--static adds the rest).
  set(PGI_PC_LIBS "")
  set(PGI_PC_DEP_FIELDS "Requires.private: ${_pgi_pc_modules}\nLibs.private: ${_pgi_pc_libs}")
else()
  # A static libphotongi.a needs its dependencies on every link line, so they are public:
  # plain `pkg-config --cflags --libs photongi` links (and --static adds theirs).
  set(PGI_PC_LIBS " ${_pgi_pc_libs}")
  set(PGI_PC_DEP_FIELDS "Requires: ${_pgi_pc_modules}")
endif()
configure_file(${PROJECT_SOURCE_DIR}/cmake/photongi.pc.in ${PROJECT_BINARY_DIR}/photongi.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/photongi.pc DESTINATION ${_pgi_pcdir})

install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/CHANGELOG.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The reference pages README links to, at the same relative paths (docs/*.md, their pictures).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs
        FILES_MATCHING PATTERN "*.md" PATTERN "*.png")

# Scene descriptions, found by name from any directory (PGI_DATADIR/scenes; CMakeLists.txt).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/scenes/ DESTINATION ${CMAKE_INSTALL_DATADIR}/photongi/scenes)
