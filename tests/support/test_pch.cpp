// Compiles tests/support/test_pch.hpp once (tests/CMakeLists.txt).
