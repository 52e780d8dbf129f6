# Builds refl-ffi with Cargo for the root CMakeLists.txt (run with cmake -P):
# the static library, the shared library with its soname, and the
# refl_config.h of the families built, all copied to OUT.
#
# Inputs (-D): CARGO, SOURCE_DIR, OUT, FEATURES (comma-separated Cargo
# features of refl-ffi), SONAME (e.g. librefl.so.0.3), VERSION (x.y.z).
# Outputs in OUT: librefl.a, librefl.so.VERSION, refl_config.h and
# native-static-libs.txt (the system libraries the static library needs, as
# rustc prints them).
cmake_minimum_required(VERSION 3.19)

set(target_dir "${OUT}/cargo")
set(common rustc -p refl-ffi --release --locked --manifest-path "${SOURCE_DIR}/Cargo.toml"
    --no-default-features --features "${FEATURES}" --message-format=json-render-diagnostics)

# Runs `cargo rustc` for one crate type; sets <prefix>_json (stdout, one
# JSON message per line) and <prefix>_err (stderr).
function(cargo_rustc prefix crate_type)
  execute_process(
    COMMAND "${CMAKE_COMMAND}" -E env "CARGO_TARGET_DIR=${target_dir}"
            "${CARGO}" ${common} --crate-type ${crate_type} -- ${ARGN}
    OUTPUT_VARIABLE json ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "cargo rustc --crate-type ${crate_type} failed (${rc}):\n${err}")
  endif()
  set(${prefix}_json "${json}" PARENT_SCOPE)
  set(${prefix}_err "${err}" PARENT_SCOPE)
endfunction()

# The value of KEY in the refl-ffi messages of REASON ("out_dir" of
# build-script-executed, "filenames" of compiler-artifact).
function(refl_ffi_message out json reason key)
  string(REPLACE ";" "\\;" json "${json}")
  string(REPLACE "\n" ";" lines "${json}")
  foreach(line IN LISTS lines)
    if(line MATCHES "\"reason\":\"${reason}\"" AND line MATCHES "refl-ffi")
      string(JSON value ERROR_VARIABLE e GET "${line}" ${key})
      if(NOT e)
        set(${out} "${value}" PARENT_SCOPE)
      endif()
    endif()
  endforeach()
endfunction()

# The static library, asking rustc for the system libraries it needs.
cargo_rustc(static staticlib --print native-static-libs)
if(NOT static_err MATCHES "native-static-libs: ([^\n]*)")
  message(FATAL_ERROR "rustc did not print native-static-libs:\n${static_err}")
endif()
file(WRITE "${OUT}/native-static-libs.txt" "${CMAKE_MATCH_1}")
refl_ffi_message(files "${static_json}" compiler-artifact filenames)
string(JSON a GET "${files}" 0)
file(COPY_FILE "${a}" "${OUT}/librefl.a")

# The shared library, linked with its soname (Cargo sets none).
cargo_rustc(shared cdylib -C "link-arg=-Wl,-soname,${SONAME}")
refl_ffi_message(files "${shared_json}" compiler-artifact filenames)
string(JSON so GET "${files}" 0)
file(COPY_FILE "${so}" "${OUT}/librefl.so.${VERSION}")

# The header's configuration, written by ffi/build.rs for these features.
refl_ffi_message(out_dir "${static_json}" build-script-executed out_dir)
if(NOT out_dir)
  # A fresh build script run prints its message; an up-to-date one too.
  message(FATAL_ERROR "no build-script-executed message from refl-ffi")
endif()
file(COPY_FILE "${out_dir}/refl_config.h" "${OUT}/refl_config.h")
