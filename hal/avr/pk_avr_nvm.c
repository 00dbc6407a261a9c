/*
 * pk_avr_nvm.c — the HAL's non-volatile store on the AVR's EEPROM (1 KB on the
 * ATmega328P, 4 KB on the ATmega2560): where the Grbl engine keeps its
 * settings, coordinate systems and startup lines so that they survive a
 * power cycle, as Grbl keeps them.
 *
 * avr-libc's block routines: a read takes a few cycles per byte; a write
 * (eeprom_update_block) rewrites only the bytes that differ, each taking
 * about 3.4 ms during which the main loop waits (interrupts stay enabled,
 * but for the four-cycle EEMPE/EEPE sequence). The engine writes only as
 * Grbl does: settings while idle, coordinate data after the queue drained.
 */
#include "pk_avr.h"

#include <avr/eeprom.h>
#include <avr/io.h>
#include <stdint.h>

/* E2END: the address of the last EEPROM byte of the part. */
#define PK_AVR_NVM_BYTES ((uint32_t)E2END + 1u)

uint32_t pk_avr_nvm_size(void *ctx)
{
    (void)ctx;
    return PK_AVR_NVM_BYTES;
}

int pk_avr_nvm_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len)
{
    (void)ctx;
    if (offset > PK_AVR_NVM_BYTES || len > PK_AVR_NVM_BYTES - offset)
        return PK_HAL_EINVAL;
    eeprom_read_block(buf, (const void *)(uintptr_t)offset, len);
    return PK_HAL_OK;
}

int pk_avr_nvm_write(void *ctx, uint32_t offset, const uint8_t *buf, size_t len)
{
    (void)ctx;
    if (offset > PK_AVR_NVM_BYTES || len > PK_AVR_NVM_BYTES - offset)
        return PK_HAL_EINVAL;
    eeprom_update_block(buf, (void *)(uintptr_t)offset, len);
    return PK_HAL_OK;
}
