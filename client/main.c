/* granularctl: command-line client of granulard (thin main; the commands live in cmd.c). */
#include <curl/curl.h>
#include "cmd.h"

int main(int argc, char **argv)
{
	if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK)
		return CTL_EXIT_SERVER;
	int rc = cmd_main(argc, argv);
	curl_global_cleanup();
	return rc;
}
