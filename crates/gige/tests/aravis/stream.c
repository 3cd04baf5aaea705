/* A minimal Aravis client for gloam's tests: streams N frames from the
 * first (only) GigE Vision device Aravis discovers, and prints one line per
 * buffer with the CRC-32C of its pixels as little-endian 16-bit values
 * (gloam's FrameMeta::pixels_crc32c), then Aravis's own statistics.
 *
 *   stream N_FRAMES [FEATURES [MAX_BUFFERS]]   FEATURES: "Name=Value Name=Value ..."
 *
 * Stops after N_FRAMES complete buffers, or after MAX_BUFFERS buffers of
 * any status.
 *
 * Output:
 *   frame <frame_id> <status> <crc32c hex> <width> <height>
 *   mean <frame_id> <mean pixel value> [<Gain feature, dB>]   (the gain when
 *       the environment has STREAM_GAIN=1: read after each frame)
 *   stats completed=<n> failures=<n> underruns=<n> resent=<n> missing=<n> seconds=<s> fps=<f>
 */
#include <arv.h>
#include <stdio.h>
#include <stdlib.h>
#include <stdint.h>

static uint32_t table[256];

static void crc_init (void)
{
	for (uint32_t i = 0; i < 256; i++) {
		uint32_t c = i;
		for (int k = 0; k < 8; k++)
			c = (c & 1) ? 0x82F63B78u ^ (c >> 1) : c >> 1;
		table[i] = c;
	}
}

static uint32_t crc_byte (uint32_t c, uint8_t b)
{
	return table[(c ^ b) & 0xff] ^ (c >> 8);
}

int main (int argc, char **argv)
{
	GError *error = NULL;
	int n_frames, got = 0, seen = 0;

	if (argc < 2) {
		fprintf (stderr, "usage: %s N_FRAMES [FEATURES]\n", argv[0]);
		return 2;
	}
	n_frames = atoi (argv[1]);
	int max_seen = argc > 3 ? atoi (argv[3]) : -1;
	crc_init ();

	ArvCamera *camera = arv_camera_new (NULL, &error);
	if (camera == NULL) {
		fprintf (stderr, "no camera: %s\n", error ? error->message : "?");
		return 1;
	}
	if (argc > 2 && argv[2][0] != '\0') {
		if (!arv_device_set_features_from_string (arv_camera_get_device (camera), argv[2], &error)) {
			fprintf (stderr, "features '%s': %s\n", argv[2], error ? error->message : "?");
			return 1;
		}
	}
	arv_camera_set_acquisition_mode (camera, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
	if (error) { fprintf (stderr, "mode: %s\n", error->message); return 1; }
	ArvStream *stream = arv_camera_create_stream (camera, NULL, NULL, &error);
	if (stream == NULL) { fprintf (stderr, "stream: %s\n", error ? error->message : "?"); return 1; }
	size_t payload = arv_camera_get_payload (camera, &error);
	ArvPixelFormat pf = arv_camera_get_pixel_format (camera, &error);
	for (int i = 0; i < 32; i++)
		arv_stream_push_buffer (stream, arv_buffer_new (payload, NULL));

	const char *sg = getenv ("STREAM_GAIN");
	int want_gain = sg != NULL && sg[0] == '1';
	gint64 t0 = g_get_monotonic_time ();
	arv_camera_start_acquisition (camera, &error);
	if (error) { fprintf (stderr, "start: %s\n", error->message); return 1; }
	while (got < n_frames && (max_seen < 0 || seen < max_seen)) {
		ArvBuffer *buffer = arv_stream_timeout_pop_buffer (stream, 5000000);
		if (buffer == NULL) {
			fprintf (stderr, "timeout after %d good frames\n", got);
			break;
		}
		seen++;
		ArvBufferStatus status = arv_buffer_get_status (buffer);
		size_t size = 0;
		const uint8_t *data = arv_buffer_get_data (buffer, &size);
		uint32_t c = 0xffffffffu;
		if (status == ARV_BUFFER_STATUS_SUCCESS) {
			if (pf == ARV_PIXEL_FORMAT_MONO_8) {
				for (size_t i = 0; i < size; i++) {
					c = crc_byte (c, data[i]);
					c = crc_byte (c, 0);
				}
			} else {
				for (size_t i = 0; i < size; i++)
					c = crc_byte (c, data[i]);
			}
			got++;
		}
		printf ("frame %" G_GUINT64_FORMAT " %d %08x %d %d\n",
			arv_buffer_get_frame_id (buffer), (int) status, c ^ 0xffffffffu,
			arv_buffer_get_image_width (buffer), arv_buffer_get_image_height (buffer));
		if (status == ARV_BUFFER_STATUS_SUCCESS && size > 0) {
			double sum = 0.0;
			size_t n = 0;
			if (pf == ARV_PIXEL_FORMAT_MONO_8) {
				for (size_t i = 0; i < size; i++, n++)
					sum += data[i];
			} else {
				for (size_t i = 0; i + 1 < size; i += 2, n++)
					sum += data[i] | (data[i + 1] << 8);
			}
			printf ("mean %" G_GUINT64_FORMAT " %.3f", arv_buffer_get_frame_id (buffer), sum / n);
			if (want_gain)
				printf (" %.6g", arv_camera_get_gain (camera, NULL));
			printf ("\n");
		}
		arv_stream_push_buffer (stream, buffer);
	}
	double seconds = (g_get_monotonic_time () - t0) / 1e6;
	arv_camera_stop_acquisition (camera, NULL);

	guint64 completed, failures, underruns, resent, missing;
	arv_stream_get_statistics (stream, &completed, &failures, &underruns);
	arv_gv_stream_get_statistics (ARV_GV_STREAM (stream), &resent, &missing);
	printf ("stats completed=%" G_GUINT64_FORMAT " failures=%" G_GUINT64_FORMAT
		" underruns=%" G_GUINT64_FORMAT " resent=%" G_GUINT64_FORMAT " missing=%" G_GUINT64_FORMAT
		" seconds=%.3f fps=%.2f\n", completed, failures, underruns, resent, missing,
		seconds, got / seconds);
	g_object_unref (stream);
	g_object_unref (camera);
	return got == n_frames || (max_seen >= 0 && seen >= max_seen) ? 0 : 1;
}
