# cmake -DSRC=addon/iblbake -DDST=stage/.../iblbake -DMANIFEST=ON|OFF -DPLATFORM=linux-x64 -P stage_files.cmake:
# the add-on's Python sources (and, for the extension, blender_manifest.toml),
# without caches or a developer's linked module.
file(COPY ${SRC}/ DESTINATION ${DST}
     FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
if(MANIFEST)  # the manifest names the one platform the module is built for
  file(READ ${SRC}/blender_manifest.toml _m)
  string(REGEX REPLACE "\nplatforms = [^\n]*" "\nplatforms = [\"${PLATFORM}\"]" _m "${_m}")
  file(WRITE ${DST}/blender_manifest.toml "${_m}")
endif()
