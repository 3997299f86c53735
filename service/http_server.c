/*
 * http_server.c: the HTTP server's lifecycle (http.h): the --bind
 * address resolved, libmicrohttpd started with the daemon's limits,
 * quiesced at shutdown and stopped; MHD's own messages logged.
 */
#include "http.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static struct {
    struct MHD_Daemon *d;
    MHD_socket quiesced_fd;
    atomic_int shutting_down;
} http = {.quiesced_fd = MHD_INVALID_SOCKET};

/* MHD's own messages (bind failures, resource limits) go to stderr with
 * the daemon's prefix. */
static void mhd_log(void *cls, const char *fmt, va_list ap)
{
    (void)cls;
    if (lrd_http_closing_on_purpose) {
        lrd_http_closing_on_purpose = 0;
        return;
    }
    char msg[512];
    vsnprintf(msg, sizeof msg, fmt, ap);
    size_t n = strlen(msg);
    while (n > 0 && msg[n - 1] == '\n')
        msg[--n] = '\0';
    fprintf(stderr, "lensrayd: libmicrohttpd: %s\n", msg);
}

int lrd_shutting_down(void)
{
    return atomic_load(&http.shutting_down);
}


const char *lrd_http_resolve(const char *bind, struct sockaddr_storage *sa,
                             int *v6)
{
    struct addrinfo hints, *ai = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    int gai = getaddrinfo(bind, NULL, &hints, &ai);
    if (gai != 0 || ai == NULL)
        return gai != 0 ? gai_strerror(gai) : "no address";
    memset(sa, 0, sizeof *sa);
    memcpy(sa, ai->ai_addr, ai->ai_addrlen);
    *v6 = ai->ai_family == AF_INET6;
    freeaddrinfo(ai);
    return NULL;
}

int lrd_http_start(void)
{
    struct sockaddr_storage sa;
    int v6 = 0;
    /* main.c resolved it already, so this fails only if the name's
     * address went away in between. */
    const char *why = lrd_http_resolve(lrd_cfg.bind, &sa, &v6);
    if (why != NULL) {
        fprintf(stderr, "lensrayd: cannot use --bind %s: %s\n", lrd_cfg.bind,
                why);
        return -1;
    }
    if (v6)
        ((struct sockaddr_in6 *)&sa)->sin6_port = htons((uint16_t)lrd_cfg.port);
    else
        ((struct sockaddr_in *)&sa)->sin_port = htons((uint16_t)lrd_cfg.port);

    /* Address reuse as MHD's default has it (SO_REUSEADDR: a restart
     * binds at once past the old connections' TIME_WAIT), not
     * MHD_OPTION_LISTENING_ADDRESS_REUSE 1, whose SO_REUSEPORT let a
     * second daemon listen on a port in use and take half its
     * connections, the jobs it was sent among them. */
    unsigned flags = MHD_USE_THREAD_PER_CONNECTION |
                     MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_ITC |
                     MHD_USE_ERROR_LOG | (v6 ? MHD_USE_IPv6 : 0);
    http.d = MHD_start_daemon(
        flags, (uint16_t)lrd_cfg.port, NULL, NULL, lrd_http_on_request, NULL,
        MHD_OPTION_EXTERNAL_LOGGER, mhd_log, NULL, MHD_OPTION_SOCK_ADDR,
        (struct sockaddr *)&sa, MHD_OPTION_CONNECTION_LIMIT,
        (unsigned)lrd_cfg.max_connections, MHD_OPTION_PER_IP_CONNECTION_LIMIT,
        (unsigned)lrd_cfg.max_per_ip, MHD_OPTION_CONNECTION_MEMORY_LIMIT,
        (size_t)lrd_cfg.conn_memory, MHD_OPTION_CONNECTION_TIMEOUT,
        (unsigned)lrd_cfg.conn_timeout, MHD_OPTION_NOTIFY_COMPLETED,
        lrd_http_on_completed, NULL, MHD_OPTION_END);
    if (http.d == NULL) {
        fprintf(stderr,
                "lensrayd: cannot listen on %s port %ld (in use, or "
                "not an address of this host?)\n",
                lrd_cfg.bind, lrd_cfg.port);
        return -1;
    }
    const union MHD_DaemonInfo *di = MHD_get_daemon_info(
        http.d, MHD_DAEMON_INFO_BIND_PORT);
    unsigned port = di != NULL ? di->port : (unsigned)lrd_cfg.port;
    char host[INET6_ADDRSTRLEN] = "";
    if (v6)
        inet_ntop(AF_INET6, &((struct sockaddr_in6 *)&sa)->sin6_addr, host,
                  sizeof host);
    else
        inet_ntop(AF_INET, &((struct sockaddr_in *)&sa)->sin_addr, host,
                  sizeof host);
    fprintf(stderr,
            "lensrayd: listening on http://%s%s%s:%u (scenes %s, %ld "
            "worker%s)\n",
            v6 ? "[" : "", host, v6 ? "]" : "", port, lrd_cfg.scenes_dir,
            lrd_cfg.workers, lrd_cfg.workers == 1 ? "" : "s");
    return 0;
}

void lrd_http_quiesce(void)
{
    atomic_store(&http.shutting_down, 1);
    if (http.d != NULL)
        http.quiesced_fd = MHD_quiesce_daemon(http.d);
    /* MHD no longer accepts, but the socket still listens, so new clients
     * would wait in the kernel's backlog until the end.  shutdown(2) makes
     * them be refused at once (a load balancer moves on) while the
     * descriptor stays valid until MHD_stop_daemon, as MHD requires. */
    if (http.quiesced_fd != MHD_INVALID_SOCKET)
        shutdown(http.quiesced_fd, SHUT_RDWR);
}

void lrd_http_stop(void)
{
    if (http.d != NULL)
        MHD_stop_daemon(http.d);
    http.d = NULL;
    /* The listening socket is ours to close once MHD has stopped. */
    if (http.quiesced_fd != MHD_INVALID_SOCKET)
        close(http.quiesced_fd);
    http.quiesced_fd = MHD_INVALID_SOCKET;
}
