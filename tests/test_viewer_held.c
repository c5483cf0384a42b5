/* photongi-view's movement keys (apps/viewer/held.h) move by the wall time they are held, not by
 * the frame time: a 50 ms tap during a 2 s frame moves 50 ms' worth, two taps in one frame move
 * twice as far, a key held across frames moves by the time between takes, and key repeats change
 * nothing. Made-up times, nothing timed. */
#include "test_util.h"

#include "held.h"

static void test_tap_in_a_slow_frame(void **state) {
    (void)state;
    held_keys h = {{0}, {0}, {0}};
    double out[HELD_KEYS];
    assert_false(held_take(&h, 10.0, out));
    held_press(&h, 0, 10.5); /* a 50 ms tap while a 2 s frame renders */
    held_release(&h, 0, 10.55);
    assert_true(held_take(&h, 12.0, out));
    assert_true(fabs(out[0] - 0.05) < 1e-9);
    for (int k = 1; k < HELD_KEYS; k++) assert_true(out[k] == 0.0);
    assert_false(held_take(&h, 14.0, out)); /* taken once */
    assert_true(out[0] == 0.0);
}

static void test_every_press_counts(void **state) {
    (void)state;
    held_keys h = {{0}, {0}, {0}};
    double out[HELD_KEYS];
    held_press(&h, 2, 1.0);
    held_release(&h, 2, 1.1);
    held_press(&h, 2, 1.3);
    held_release(&h, 2, 1.35);
    held_press(&h, 3, 1.4); /* another key in the same frame */
    held_release(&h, 3, 1.6);
    held_take(&h, 3.0, out);
    assert_true(fabs(out[2] - 0.15) < 1e-9);
    assert_true(fabs(out[3] - 0.2) < 1e-9);
}

static void test_held_across_frames(void **state) {
    (void)state;
    held_keys h = {{0}, {0}, {0}};
    double out[HELD_KEYS];
    held_press(&h, 5, 0.0);
    assert_true(held_take(&h, 1.0, out));
    assert_true(fabs(out[5] - 1.0) < 1e-9);
    held_press(&h, 5, 1.2); /* a key repeat: no new start */
    assert_true(held_take(&h, 1.5, out));
    assert_true(fabs(out[5] - 0.5) < 1e-9);
    held_release(&h, 5, 1.7);
    assert_true(held_take(&h, 3.0, out));
    assert_true(fabs(out[5] - 0.2) < 1e-9);
    assert_false(held_take(&h, 4.0, out));
    assert_true(out[5] == 0.0);
}

static void test_stray_and_out_of_range(void **state) {
    (void)state;
    held_keys h = {{0}, {0}, {0}};
    double out[HELD_KEYS];
    held_release(&h, 1, 5.0); /* released, never pressed (pressed before the window had focus) */
    held_press(&h, -1, 1.0);
    held_press(&h, HELD_KEYS, 1.0);
    held_release(&h, HELD_KEYS, 2.0);
    assert_false(held_take(&h, 6.0, out));
    held_press(&h, 4, 3.0); /* a release stamped before the press moves nothing */
    held_release(&h, 4, 2.5);
    assert_false(held_take(&h, 6.0, out));
}

TU_MAIN("viewer held", NULL, NULL, cmocka_unit_test(test_tap_in_a_slow_frame),
        cmocka_unit_test(test_every_press_counts), cmocka_unit_test(test_held_across_frames),
        cmocka_unit_test(test_stray_and_out_of_range))
