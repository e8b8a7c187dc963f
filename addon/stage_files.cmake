# cmake -DSRC=addon/iblbake -DDST=stage/iblbake -P stage_files.cmake:
# the add-on's sources (Python and the extension manifest), without caches
# or a developer's linked module.
file(COPY ${SRC}/ DESTINATION ${DST}
     FILES_MATCHING PATTERN "*.py" PATTERN "*.toml"
     PATTERN "__pycache__" EXCLUDE)
