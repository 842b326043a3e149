/* The STM32's 96-bit factory unique id (RM0383 24.1). */
#ifndef UID_H
#define UID_H

#include <stdint.h>

/* Copies 12 bytes; zeros if the id cannot be read (a model without that memory). */
void uid_read(uint8_t uid[12]);

#endif /* UID_H */
