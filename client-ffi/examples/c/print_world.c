/* Joins an Inertia server through libinertia and prints what it sees.
 *
 *   print_world ADDRESS TOKEN_HEX [SECONDS]
 *   print_world --dev CREDENTIALS_FILE [SECONDS]
 *
 * Each second it prints the picture (how many entities, the first few
 * with their names and positions, the soft bodies and fluids with how
 * many of their points are known) and the connection's statistics. It
 * exits 0 when it saw entities move, 1 otherwise. */

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "inertia.h"

#define MAX_ENTITIES 20000
#define MAX_POINTS 16384

static int fail(const char *what) {
    char message[512];
    inertia_last_error(message, sizeof message);
    fprintf(stderr, "%s: %s\n", what, message);
    return 1;
}

static int hex_value(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static void sleep_ms(long ms) {
    struct timespec t = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&t, NULL);
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s ADDRESS TOKEN_HEX [SECONDS] | --dev CREDENTIALS [SECONDS]\n", argv[0]);
        return 2;
    }
    if (inertia_abi_version() != INERTIA_ABI_VERSION) {
        fprintf(stderr, "libinertia speaks ABI %u, this program %u\n", inertia_abi_version(), INERTIA_ABI_VERSION);
        return 1;
    }
    int seconds = argc > 3 ? atoi(argv[3]) : 3;
    InertiaClient *client = NULL;
    if (strcmp(argv[1], "--dev") == 0) {
        if (inertia_connect_dev(argv[2], 0, &client) != INERTIA_STATUS_OK) return fail("connect");
    } else {
        size_t n = strlen(argv[2]) / 2;
        uint8_t *token = malloc(n ? n : 1);
        for (size_t i = 0; i < n; i++) {
            int hi = hex_value(argv[2][2 * i]), lo = hex_value(argv[2][2 * i + 1]);
            if (hi < 0 || lo < 0) {
                fprintf(stderr, "the token is not hex\n");
                return 2;
            }
            token[i] = (uint8_t)(hi * 16 + lo);
        }
        /* Predict the own avatar: it answers the input at once. */
        InertiaConnectOptions options = {.predict = 1};
        InertiaStatus s = inertia_connect_with(argv[1], token, n, &options, &client);
        free(token);
        if (s != INERTIA_STATUS_OK) return fail("connect");
    }

    InertiaServerInfo info;
    inertia_server_info(client, &info);
    /* Walk: one input per tick from now on, until changed. */
    inertia_set_input(client, 1.0f, 0.0f, 0.0f, 0);
    printf("joined %s (%s) as client %llu: %u ticks/s, %u snapshots/s\n", info.server_version,
           info.game, (unsigned long long)info.client_id, info.tick_hz, info.snapshot_hz);
    /* Say hello: the sandbox's chat request (kind 1, the line's length,
       its UTF-8), which its rules tell everyone, us included. */
    static const uint8_t chat[] = {1, 5, 'h', 'e', 'l', 'l', 'o'};
    if (inertia_send_message(client, chat, sizeof chat, INERTIA_DELIVERY_RELIABLE) != INERTIA_STATUS_OK)
        return fail("send message");

    static InertiaEntityState states[MAX_ENTITIES];
    static float points[3 * MAX_POINTS];
    static uint8_t present[MAX_POINTS];
    double first_x = 0, last_x = 0;
    uint32_t watched = 0;
    int moved = 0, spawned = 0, heard = 0;
    for (int frame = 0; frame < seconds * 20; frame++) {
        sleep_ms(50);
        InertiaEvent event;
        for (;;) {
            if (inertia_poll_event(client, &event) != INERTIA_STATUS_OK) return fail("poll");
            if (event.kind == INERTIA_EVENT_KIND_NONE) break;
            if (event.kind == INERTIA_EVENT_KIND_SPAWNED) spawned++;
            /* The sandbox's chat event: kind 7, the client, the line. */
            if (event.kind == INERTIA_EVENT_KIND_MESSAGE && event.data_len > 0 && event.data[0] == 7) heard++;
            if (event.kind == INERTIA_EVENT_KIND_DISCONNECTED) {
                printf("disconnected: %s\n", event.text);
                inertia_disconnect(client);
                return 1;
            }
        }
        size_t count = 0;
        InertiaStatus s = inertia_sample(client, states, MAX_ENTITIES, &count);
        if (s != INERTIA_STATUS_OK && s != INERTIA_STATUS_BUFFER_TOO_SMALL) return fail("sample");
        size_t drawn = count < MAX_ENTITIES ? count : MAX_ENTITIES;
        /* Follow the first dynamic body that moves. */
        for (size_t i = 0; i < drawn && watched == 0; i++) {
            InertiaEntityInfo e;
            if (inertia_entity_info(client, states[i].id, &e) == INERTIA_STATUS_OK &&
                e.kind == INERTIA_ENTITY_KIND_DYNAMIC) {
                watched = states[i].id;
                first_x = states[i].x + states[i].y + states[i].z;
            }
        }
        for (size_t i = 0; i < drawn; i++) {
            if (states[i].id == watched) last_x = states[i].x + states[i].y + states[i].z;
        }
        if (watched && last_x != first_x) moved = 1;
        if (frame % 20 == 19) {
            printf("t=%ds: %zu entities in the picture, %d described\n", (frame + 1) / 20, count, spawned);
            int shown = 0;
            for (size_t i = 0; i < drawn && shown < 3; i++) {
                InertiaEntityInfo e;
                if (inertia_entity_info(client, states[i].id, &e) != INERTIA_STATUS_OK) continue;
                printf("  %u %-20s at (%.3f, %.3f, %.3f)\n", e.id, e.name, states[i].x, states[i].y, states[i].z);
                shown++;
            }
            /* Soft bodies and fluids: entities described as point sets. */
            for (uint32_t id = 1; id < 100000; id++) {
                InertiaEntityInfo e;
                if (inertia_entity_info(client, id, &e) != INERTIA_STATUS_OK || e.shape != INERTIA_SHAPE_KIND_POINT_SET) continue;
                size_t n = 0;
                s = inertia_point_set(client, id, points, present, MAX_POINTS, &n);
                if (s != INERTIA_STATUS_OK && s != INERTIA_STATUS_BUFFER_TOO_SMALL) return fail("point set");
                size_t known = 0;
                for (size_t i = 0; i < n && i < MAX_POINTS; i++) known += present[i];
                size_t indices = 0;
                inertia_point_set_triangles(client, id, NULL, 0, &indices);
                printf("  %s %s: %zu of %zu points known, %zu triangles\n",
                       e.kind == INERTIA_ENTITY_KIND_FLUID ? "fluid" : "soft body", e.name, known, n, indices / 3);
                id += e.points;
            }
            InertiaStats stats;
            inertia_stats(client, &stats);
            printf("  rtt %.1f ms, jitter %.1f ms, %.1f kbit/s in, %.1f out, %llu snapshots, loss %.3f\n",
                   stats.rtt_ms, stats.jitter_ms, stats.kbps, stats.kbps_out,
                   (unsigned long long)stats.snapshots_received, stats.loss);
            printf("  inputs for tick %llu: %llu on time, %llu late, %llu refused\n",
                   (unsigned long long)stats.input_tick, (unsigned long long)stats.inputs_on_time,
                   (unsigned long long)stats.inputs_late, (unsigned long long)stats.inputs_refused);
            printf("  prediction: error p99 %.1f mm, max %.1f mm, largest snap %.2f mm, %llu corrections\n",
                   stats.prediction_error_p99_m * 1e3, stats.prediction_error_max_m * 1e3,
                   stats.prediction_snap_max_m * 1e3, (unsigned long long)stats.prediction_corrections);
        }
    }
    /* The kill-cam: the last second again, beside the live match. */
    if (inertia_kill_cam(client, 1.0f, 1.0f, INERTIA_NO_ENTITY) != INERTIA_STATUS_OK) return fail("kill-cam");
    size_t replayed = 0;
    for (int frame = 0; frame < 60; frame++) {
        sleep_ms(50);
        size_t count = 0;
        InertiaStatus s = inertia_replay_sample(client, states, MAX_ENTITIES, &count);
        if (s != INERTIA_STATUS_OK && s != INERTIA_STATUS_BUFFER_TOO_SMALL) return fail("replay sample");
        if (count > replayed) replayed = count;
        InertiaEvent event;
        for (;;) {
            if (inertia_poll_event(client, &event) != INERTIA_STATUS_OK) return fail("poll");
            if (event.kind == INERTIA_EVENT_KIND_NONE) break;
            if (event.kind == INERTIA_EVENT_KIND_REPLAY_STARTED)
                printf("replay: ticks %.0f to %.0f\n", event.from_tick, event.to_tick);
            if (event.kind == INERTIA_EVENT_KIND_REPLAY_REFUSED) printf("replay refused: %s\n", event.text);
            if (event.kind == INERTIA_EVENT_KIND_REPLAY_ENDED) {
                printf("replay ended: %s, %zu entities in its picture\n", event.text, replayed);
                frame = 60;
            }
        }
    }
    /* The game's match state: each property by name, as of the tick drawn. */
    InertiaPropertyValue values[32];
    size_t n_values = 0;
    if (inertia_match_state(client, values, 32, &n_values) != INERTIA_STATUS_OK) return fail("match state");
    for (uint32_t i = 0; i < n_values && i < 32; i++) {
        InertiaPropertyDecl decl;
        if (inertia_property_decl(client, 1, i, &decl) != INERTIA_STATUS_OK) return fail("property");
        printf("match %s = %llu\n", decl.name, (unsigned long long)values[i].as_u64);
    }
    inertia_disconnect(client);
    printf("heard %d chat line%s\n", heard, heard == 1 ? "" : "s");
    printf(moved ? "saw the world move\n" : "saw nothing move\n");
    return moved && heard > 0 ? 0 : 1;
}
