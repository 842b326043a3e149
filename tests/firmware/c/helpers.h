/* Shared helpers for the scheduler and command tests. */
#ifndef HELPERS_H
#define HELPERS_H

#include "fake_board.h"

#define H_MAX_FRAMES 2048
extern fake_frame_t g_frames[H_MAX_FRAMES];

/* Decode everything captured so far into g_frames; returns the count (-1: bad frame). */
int h_frames(const fake_board_t *b);
void h_send_configure(fake_board_t *b, const stac_configure_t *c, uint16_t seq);
void h_send_empty(fake_board_t *b, uint8_t type, uint16_t seq);
/* Collect the SAMPLEs among the first n frames (up to cap); returns how many. */
int h_samples(int n, stac_sample_t *out, int cap);

#endif /* HELPERS_H */
