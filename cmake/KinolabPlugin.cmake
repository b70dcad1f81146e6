# kinolab_add_plugin(<name> SOURCES <file>... [LIBRARIES <target>...] [ON_USE])
#
# Builds one plugin from sources that register it with KINOLAB_REGISTER_PLUGINS.
# - Inside the kinolab tree (a folder under plugins/), the plugin is compiled into kinolab
#   itself, and the generated built-in list calls its entry point: adding or removing the
#   folder is the only change.
# - ON_USE (in the tree): a plugin whose libraries are heavy to load (OMPL, Ceres) becomes a
#   module, kinolab_modules/kinolab_module_<name>.so beside the plugins library, with a
#   manifest of what it declares written at build time; kinolab knows its plugins from the
#   manifest and loads the module only when one of them is made, so a command that never uses
#   them never loads their libraries.
# - In a project that did find_package(kinolab), it becomes a shared library <name> that
#   `kinolab --plugin path/to/lib<name>.so` (or an experiment's `plugins:` list) loads.
function(kinolab_add_plugin name)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "ON_USE" "" "SOURCES;LIBRARIES")
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "kinolab_add_plugin(${name}): no SOURCES")
  endif()
  if(NOT name MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "kinolab_add_plugin(${name}): the name must be a C identifier")
  endif()
  if(KINOLAB_IN_TREE AND ARG_ON_USE)
    set(target kinolab_module_${name})
    add_library(${target} MODULE ${ARG_SOURCES})
    set_target_properties(${target} PROPERTIES PREFIX ""
      LIBRARY_OUTPUT_DIRECTORY ${KINOLAB_MODULE_DIR} INSTALL_RPATH "$ORIGIN/..")
    kinolab_set_warnings(${target})
    set_property(GLOBAL APPEND PROPERTY KINOLAB_ON_USE_PLUGINS ${name})
    install(TARGETS ${target} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/kinolab_modules)
  elseif(KINOLAB_IN_TREE)
    set(target kinolab_plugin_${name})
    add_library(${target} OBJECT ${ARG_SOURCES})
    target_compile_definitions(${target} PRIVATE
      KINOLAB_BUILTIN_PLUGIN_ENTRY=kinolab_builtin_register_${name})
    kinolab_set_warnings(${target})
    set_property(GLOBAL APPEND PROPERTY KINOLAB_BUILTIN_PLUGINS ${name})
  else()
    set(target ${name})
    add_library(${target} MODULE ${ARG_SOURCES})
  endif()
  target_link_libraries(${target} PUBLIC kinolab::framework ${ARG_LIBRARIES})
endfunction()
