# kinolab_add_plugin(<name> SOURCES <file>... [LIBRARIES <target>...])
#
# Builds one plugin from sources that register it with KINOLAB_REGISTER_PLUGINS.
# - Inside the kinolab tree (a folder under plugins/), the plugin is compiled into kinolab
#   itself, and the generated built-in list calls its entry point: adding or removing the
#   folder is the only change.
# - In a project that did find_package(kinolab), it becomes a shared library <name> that
#   `kinolab --plugin path/to/lib<name>.so` (or an experiment's `plugins:` list) loads.
function(kinolab_add_plugin name)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "" "" "SOURCES;LIBRARIES")
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "kinolab_add_plugin(${name}): no SOURCES")
  endif()
  if(NOT name MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "kinolab_add_plugin(${name}): the name must be a C identifier")
  endif()
  if(KINOLAB_IN_TREE)
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
