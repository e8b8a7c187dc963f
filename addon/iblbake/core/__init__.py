"""iblbake's add-on core: no bpy here. It takes arrays and a settings object
(core.settings.BakeSettings) and calls the native module; the Blender side
(the modules one folder up) only translates between bpy and these types."""
