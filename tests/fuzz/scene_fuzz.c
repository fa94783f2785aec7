/* libFuzzer harness: the scene parser (scene_parse) and the advice estimate it feeds, on arbitrary bytes. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "advice.h"
#include "scene.h"

static advice_model_t *model;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
	size_t len;
	const char *text = advice_model_builtin(&len);
	char err[256];
	model = advice_model_create(text, len, err, sizeof err);
	return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	scene_t s;
	char err[512];
	memset(err, 0x55, sizeof err);   /* the message must be terminated whatever was there */
	int r = scene_parse((const char *)data, size, &s, err, sizeof err);
	if (r != SCENE_OK) {
		/* The contract: a negative code and one NUL-terminated line. */
		if (r >= 0 || !memchr(err, '\0', sizeof err) || strchr(err, '\n'))
			__builtin_trap();
		return 0;
	}
	/* A valid scene must be usable by what the daemon and the engine do next. */
	volatile double v = scene_box_volume(&s) + scene_particle_volume(&s);
	(void)v;
	if (model) {
		static advice_t a;
		if (advice_estimate(model, &s, 1 + (int)(s.seed % 64), &a, err, sizeof err) == 0) {
			json_t *j = advice_json(&a);
			json_decref(j);
		}
	}
	return 0;
}
