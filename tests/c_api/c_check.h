/* The checks shared by the C99 test programs (c99_inverse.c, c99_loop.c): CHECK(cond, ...)
 * and OK(call) count a failure and print where; expect_error checks a failing call's status
 * and message. Each program includes it once and returns failures ? 1 : 0. */
#ifndef HYSTERON_C_TEST_CHECK_H
#define HYSTERON_C_TEST_CHECK_H
#include <stdio.h>
#include <string.h>

#include "hysteron/hysteron.h"

static int failures = 0;

#define CHECK(cond, ...)                                       \
  do {                                                         \
    if (!(cond)) {                                             \
      ++failures;                                              \
      fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
      fprintf(stderr, __VA_ARGS__);                            \
      fprintf(stderr, "\n");                                   \
    }                                                          \
  } while (0)

/* A call that must succeed; prints the library's message otherwise. */
#define OK(call)                                                                          \
  do {                                                                                    \
    hysteron_status st_ = (call);                                                         \
    if (st_ != HYSTERON_OK) {                                                             \
      ++failures;                                                                         \
      fprintf(stderr, "FAIL %s:%d: %s -> %s: %s\n", __FILE__, __LINE__, #call,            \
              hysteron_status_name(st_), hysteron_last_error());                          \
    }                                                                                     \
  } while (0)

/* A call that must fail with `expected` and a message containing `needle`. */
static void expect_error(const char* what, hysteron_status got, hysteron_status expected, const char* needle) {
  const char* msg = hysteron_last_error();
  if (got != expected) {
    ++failures;
    fprintf(stderr, "FAIL %s: got %s, expected %s (message: %s)\n", what, hysteron_status_name(got),
            hysteron_status_name(expected), msg);
    return;
  }
  if (msg == NULL || msg[0] == '\0' || strstr(msg, needle) == NULL) {
    ++failures;
    fprintf(stderr, "FAIL %s: message \"%s\" does not contain \"%s\"\n", what, msg ? msg : "(null)", needle);
    return;
  }
  printf("ok   %s: %s: %s\n", what, hysteron_status_name(got), msg);
}

#endif
