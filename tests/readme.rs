//! The README's C++ example is `cpp_tests/example.cpp` verbatim (the C++
//! tests compile and run that file; the Rust example is a doctest of this
//! crate through `#![doc = include_str!("../README.md")]`).

#[test]
fn readme_cpp_example_is_the_tested_file() {
    let root = env!("CARGO_MANIFEST_DIR");
    let readme = std::fs::read_to_string(format!("{root}/README.md")).unwrap();
    let example = std::fs::read_to_string(format!("{root}/cpp_tests/example.cpp")).unwrap();
    let start = readme.find("```cpp\n").expect("README has a ```cpp block") + "```cpp\n".len();
    let len = readme[start..]
        .find("\n```")
        .expect("the ```cpp block is closed");
    assert_eq!(
        &readme[start..start + len],
        example.trim_end(),
        "README's C++ example differs from cpp_tests/example.cpp"
    );
}
