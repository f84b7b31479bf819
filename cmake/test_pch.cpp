// The translation unit that builds the tests' precompiled header
// (lookboth_test_precompiled_header in LookbothHelpers.cmake); it has no code.
