#define _XOPEN_SOURCE 600 /* posix_openpt, grantpt, ptsname */
/* The byte-stream transports wdrctl uses for serial boards and emulators (transport_serial.c):
 * a pseudo-terminal stands in for the tty, local listeners for QEMU's unix and TCP servers.
 * Bytes must pass unchanged both ways (raw mode: no CR/LF translation, no echo, no signals from
 * control bytes), and absent boards and bad addresses get their own errors. */
#include "transport.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

/* Every byte value, including the ones a cooked tty would eat (^C, ^D, CR, LF, XON/XOFF). */
static void all_bytes(uint8_t *b)
{
    for (int i = 0; i < 256; i++)
        b[i] = (uint8_t)(255 - i);
}

static void expect_fd_gets(int fd, const uint8_t *want, size_t n)
{
    uint8_t got[256];
    size_t have = 0;
    for (int tries = 0; have < n && tries < 200; tries++) {
        ssize_t r = read(fd, got + have, n - have);
        if (r > 0)
            have += (size_t)r;
        else
            usleep(5000);
    }
    assert_int_equal(have, n);
    assert_memory_equal(got, want, n);
}

static void round_trip(wdr_transport *t, int peer)
{
    uint8_t b[256], got[256];
    all_bytes(b);
    assert_int_equal(wdr_transport_send(t, b, sizeof b, 1000), WDR_OK);
    expect_fd_gets(peer, b, sizeof b);
    assert_int_equal(write(peer, b, sizeof b), (ssize_t)sizeof b);
    assert_int_equal(wdr_transport_recv_exact(t, got, sizeof got, 1000), WDR_OK);
    assert_memory_equal(got, b, sizeof b);
    assert_int_equal(wdr_transport_recv(t, got, 1, 50), WDR_E_TIMEOUT);
}

static void serial_pty_passes_every_byte(void **state)
{
    (void)state;
    char err[256];
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    assert_true(master >= 0);
    assert_int_equal(grantpt(master), 0);
    assert_int_equal(unlockpt(master), 0);
    char spec[128];
    snprintf(spec, sizeof spec, "serial:%s@921600", ptsname(master));
    wdr_transport *t;
    assert_int_equal(wdr_transport_open(spec, &t, err, sizeof err), WDR_OK);
    fcntl(master, F_SETFL, O_NONBLOCK);
    round_trip(t, master);
    wdr_transport_close(t);
    close(master);
}

static void serial_errors(void **state)
{
    (void)state;
    char err[256];
    wdr_transport *t;
    assert_int_equal(wdr_transport_open("serial:/nonexistent/ttyX", &t, err, sizeof err), WDR_E_ABSENT);
    assert_non_null(strstr(err, "/nonexistent/ttyX"));
    assert_int_equal(wdr_transport_open("serial:/dev/null@115200", &t, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "not a serial port"));
    assert_int_equal(wdr_transport_open("serial:/dev/ttyS0@12345", &t, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "12345"));
    assert_int_equal(wdr_transport_open("bogus:x", &t, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "tcp:HOST:PORT"));
}

static void unix_socket_like_qemu(void **state)
{
    (void)state;
    char err[256], dir[] = "/tmp/wdr_stream_XXXXXX";
    assert_non_null(mkdtemp(dir));
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s/uart.sock", dir);
    char spec[160];
    snprintf(spec, sizeof spec, "unix:%s", sa.sun_path);
    wdr_transport *t;
    assert_int_equal(wdr_transport_open(spec, &t, err, sizeof err), WDR_E_ABSENT);
    int ls = socket(AF_UNIX, SOCK_STREAM, 0);
    assert_int_equal(bind(ls, (struct sockaddr *)&sa, sizeof sa), 0);
    assert_int_equal(listen(ls, 1), 0);
    assert_int_equal(wdr_transport_open(spec, &t, err, sizeof err), WDR_OK);
    int peer = accept(ls, NULL, NULL);
    fcntl(peer, F_SETFL, O_NONBLOCK);
    round_trip(t, peer);
    close(peer); /* the emulator went away */
    uint8_t b[4];
    assert_int_equal(wdr_transport_recv(t, b, sizeof b, 500), WDR_E_IO);
    wdr_transport_close(t);
    close(ls);
    unlink(sa.sun_path);
    rmdir(dir);
}

static void tcp_like_qemu(void **state)
{
    (void)state;
    char err[256], spec[64];
    int ls = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK)};
    socklen_t len = sizeof sa;
    assert_int_equal(bind(ls, (struct sockaddr *)&sa, sizeof sa), 0);
    assert_int_equal(listen(ls, 1), 0);
    assert_int_equal(getsockname(ls, (struct sockaddr *)&sa, &len), 0);
    snprintf(spec, sizeof spec, "tcp:127.0.0.1:%u", ntohs(sa.sin_port));
    wdr_transport *t;
    assert_int_equal(wdr_transport_open(spec, &t, err, sizeof err), WDR_OK);
    int peer = accept(ls, NULL, NULL);
    fcntl(peer, F_SETFL, O_NONBLOCK);
    round_trip(t, peer);
    wdr_transport_close(t);
    close(peer);
    close(ls);
    assert_int_equal(wdr_transport_open("tcp:nohostport", &t, err, sizeof err), WDR_E_INVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(serial_pty_passes_every_byte),
        cmocka_unit_test(serial_errors),
        cmocka_unit_test(unix_socket_like_qemu),
        cmocka_unit_test(tcp_like_qemu),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
