// The holder of the precompiled Catch2 header that every test reuses (tests/CMakeLists.txt): it has no code of its
// own, but CMake builds a precompiled header only for a target with a source file.
