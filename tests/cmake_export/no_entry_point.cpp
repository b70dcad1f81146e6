// A shared library that is not a kinolab plugin: it has no entry point.
extern "C" int not_a_kinolab_plugin() { return 42; }
