/* Round trip through the installed C ABI: a GPI model from a JSON string, forwards then
 * its exact inverse. Usage: consumer [MODEL.json] */
#include <math.h>
#include <stdio.h>

#include <hysteron/hysteron.h>

int main(int argc, char** argv) {
  const char* json = "{\"model\": \"gpi\", \"envelope\": \"tanh\", \"c\": [1, 2, -0.6, 0.6], \"q\": 0.8,"
                     " \"n\": 10, \"rho\": 0.4, \"tau\": 5, \"alpha\": 0.03, \"input_limits\": [0, 0.6]}";
  hysteron_params* params = NULL;
  hysteron_model* model = NULL;
  hysteron_inverse* inverse = NULL;
  double worst = 0.0;
  int k;
  hysteron_status st = argc > 1 ? hysteron_params_from_file(argv[1], &params) : hysteron_params_from_json(json, &params);
  if (st != HYSTERON_OK || hysteron_model_create(params, &model) != HYSTERON_OK ||
      hysteron_inverse_create(params, -HUGE_VAL, HUGE_VAL, &inverse) != HYSTERON_OK) {
    fprintf(stderr, "consumer: %s\n", hysteron_last_error());
    return 1;
  }
  for (k = 0; k < 1000; ++k) {
    const double x = 0.3 + 0.25 * sin(0.01 * k) * cos(0.003 * k);
    double y = 0.0, xi = 0.0;
    if (hysteron_model_step(model, x, &y) != HYSTERON_OK || hysteron_inverse_step(inverse, y, &xi, NULL) != HYSTERON_OK)
      return 1;
    if (fabs(xi - x) > worst) worst = fabs(xi - x);
  }
  printf("C consumer (hysteron %s): max round-trip error %.3g\n", hysteron_version_string(), worst);
  hysteron_inverse_free(inverse);
  hysteron_model_free(model);
  hysteron_params_free(params);
  return worst < 1e-12 ? 0 : 1;
}
