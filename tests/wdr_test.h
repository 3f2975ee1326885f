/* Helpers every cmocka test may use; include after <cmocka.h>. */
#ifndef WDR_TEST_H
#define WDR_TEST_H
#include <math.h>

/* cmocka 1.1.5 (Debian 12) has no assert_double_equal; this one also names both values. */
#ifndef assert_double_equal
#define assert_double_equal(a, b, eps)                                                                     \
    do {                                                                                                   \
        double a_ = (a), b_ = (b);                                                                         \
        if (!(fabs(a_ - b_) <= (eps)))                                                                     \
            fail_msg("%s = %.12g, expected %s = %.12g within %g", #a, a_, #b, b_, (double)(eps));          \
    } while (0)
#endif

#endif
