// check.hpp: a tiny in-house check macro set for refl's C++ tests.
//
//   CHECK(cond)                 records a failure if cond is false
//   CHECK_EQ(a, b)              records a failure if !(a == b), printing both
//   CHECK_STATUS(call, status)  records a failure unless call returns status
//   REQUIRE(cond)               like CHECK, but ends the test at once
//   return check::finish("name") at the end of main: prints a summary and
//                               returns the process exit code for ctest
//
// No framework, no downloads: every test is its own executable and ctest
// runs it.
#ifndef REFL_CPP_TESTS_CHECK_HPP
#define REFL_CPP_TESTS_CHECK_HPP

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "refl.h"

namespace check {

inline int& failures() {
    static int n = 0;
    return n;
}
inline long& checks() {
    static long n = 0;
    return n;
}

inline void fail(const char* file, int line, const std::string& what) {
    ++failures();
    std::fprintf(stderr, "%s:%d: check failed: %s\n", file, line, what.c_str());
}

template <class A, class B>
std::string describe_eq(const char* ea, const char* eb, const A& a, const B& b) {
    std::ostringstream s;
    s << ea << " == " << eb << " (" << a << " vs " << b << ")";
    return s.str();
}

inline std::string status_name(uint32_t s) {
    std::ostringstream o;
    o << s << " \"" << refl_status_string(s) << "\"";
    return o.str();
}

inline int finish(const char* name) {
    if (failures() == 0) {
        std::printf("%s: OK (%ld checks)\n", name, checks());
        return EXIT_SUCCESS;
    }
    std::printf("%s: FAILED (%d of %ld checks)\n", name, failures(), checks());
    return EXIT_FAILURE;
}

}  // namespace check

#define CHECK(cond)                                                                     \
    do {                                                                                \
        ++check::checks();                                                              \
        if (!(cond)) check::fail(__FILE__, __LINE__, #cond);                            \
    } while (0)

#define CHECK_EQ(a, b)                                                                  \
    do {                                                                                \
        ++check::checks();                                                              \
        const auto& check_a_ = (a);                                                     \
        const auto& check_b_ = (b);                                                     \
        if (!(check_a_ == check_b_))                                                    \
            check::fail(__FILE__, __LINE__, check::describe_eq(#a, #b, check_a_, check_b_)); \
    } while (0)

#define CHECK_STATUS(call, expected)                                                    \
    do {                                                                                \
        ++check::checks();                                                              \
        const uint32_t check_got_ = static_cast<uint32_t>(call);                        \
        const uint32_t check_want_ = static_cast<uint32_t>(expected);                   \
        if (check_got_ != check_want_)                                                  \
            check::fail(__FILE__, __LINE__,                                             \
                        std::string(#call) + " returned " + check::status_name(check_got_) + \
                            ", expected " + check::status_name(check_want_));           \
    } while (0)

#define REQUIRE(cond)                                                                   \
    do {                                                                                \
        ++check::checks();                                                              \
        if (!(cond)) {                                                                  \
            check::fail(__FILE__, __LINE__, std::string("required: ") + #cond);         \
            std::exit(EXIT_FAILURE);                                                    \
        }                                                                               \
    } while (0)

#endif  // REFL_CPP_TESTS_CHECK_HPP
