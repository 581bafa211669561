/* A Cyclone DDS 0.10 peer (the Cyclone of ROS 2 Humble and Jazzy) that talks to the node as a ROS 2 robot does,
 * without the package's code: types from ros_msgs.idl compiled with `idlc -t` (no XTypes type information, like
 * rmw_cyclonedds_cpp), QoS as rmw_cyclonedds_cpp sets them, data serialised by Cyclone's own C serialiser.
 *
 * Usage: peer DOMAIN PREFIX: the topics are PREFIX/camera_info, PREFIX/detections, PREFIX/tf, PREFIX/tf_static (out)
 * and PREFIX/fruit/detections (in), on DDS as rt/... (PREFIX "" for /camera_info...). Commands on stdin, one per line:
 *   pub KIND HEX   KIND is camera_info, detections, tf or tf_static; HEX is a CDR message (4-byte header first):
 *                  it is checked and read into the C type with Cyclone's stream code, then written with dds_write
 *   quit
 * On stdout: "ready", "matched" (once the detections writer has a subscriber), "pub KIND", and for every
 * vision_msgs/Detection3DArray on PREFIX/fruit/detections taken with dds_take:
 *   det3d N SEC NANOSEC FRAME, then N lines "fruit ID X Y Z SX SY SZ COV_XX CLASS SCORE".
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <unistd.h>

#include "dds/dds.h"
#include "dds/ddsi/ddsi_cdrstream.h"
#include "ros_msgs.h"

#define DDS_OK(x) do { if ((x) < 0) { fprintf (stderr, "peer: %s failed: %d\n", #x, (int) (x)); exit (2); } } while (0)

struct kind { const char *name; const char *topic; const dds_topic_descriptor_t *desc; int history; int transient; dds_entity_t writer; };

static dds_qos_t *rmw_qos (int history, int reliable, int transient)
{
  /* rmw_cyclonedds_cpp's create_readwrite_qos for a profile */
  dds_qos_t *qos = dds_create_qos ();
  dds_qset_writer_data_lifecycle (qos, false);
  dds_qset_history (qos, DDS_HISTORY_KEEP_LAST, history);
  if (reliable)
    dds_qset_reliability (qos, DDS_RELIABILITY_RELIABLE, DDS_INFINITY);
  else
    dds_qset_reliability (qos, DDS_RELIABILITY_BEST_EFFORT, 0);
  if (transient) {
    dds_qset_durability (qos, DDS_DURABILITY_TRANSIENT_LOCAL);
    dds_qset_durability_service (qos, 0, DDS_HISTORY_KEEP_LAST, history, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  } else {
    dds_qset_durability (qos, DDS_DURABILITY_VOLATILE);
  }
  dds_qset_liveliness (qos, DDS_LIVELINESS_AUTOMATIC, DDS_INFINITY);
  return qos;
}

static unsigned char *from_hex (const char *hex, uint32_t *size)
{
  size_t n = strlen (hex) / 2;
  unsigned char *out = malloc (n ? n : 1);
  for (size_t i = 0; i < n; i++) {
    unsigned v;
    sscanf (hex + 2 * i, "%2x", &v);
    out[i] = (unsigned char) v;
  }
  *size = (uint32_t) n;
  return out;
}

static void publish (struct kind *k, const char *hex)
{
  uint32_t size, off = 0;
  unsigned char *data = from_hex (hex, &size);
  if (size < 4 || data[0] != 0 || data[1] != 1) {
    fprintf (stderr, "peer: %s: expected a CDR_LE message\n", k->name);
    exit (2);
  }
  /* the payload after the 4-byte encapsulation header, checked as Cyclone checks received data */
  if (dds_stream_normalize_data ((char *) data + 4, &off, size - 4, false, CDR_ENC_VERSION_1, k->desc->m_ops) == NULL) {
    fprintf (stderr, "peer: %s: the bytes do not match the type\n", k->name);
    exit (2);
  }
  void *sample = dds_alloc (k->desc->m_size);
  dds_istream_t is;
  dds_istream_init (&is, size - 4, data + 4, CDR_ENC_VERSION_1);
  dds_stream_read (&is, sample, k->desc->m_ops);
  DDS_OK (dds_write (k->writer, sample));
  dds_sample_free (sample, k->desc, DDS_FREE_ALL);
  free (data);
  printf ("pub %s\n", k->name);
}

static void print_detections (dds_entity_t reader)
{
  void *samples[8] = { NULL };
  dds_sample_info_t infos[8];
  int n = dds_take (reader, samples, infos, 8, 8);
  for (int i = 0; i < n; i++) {
    if (!infos[i].valid_data)
      continue;
    const vision_msgs_msg_dds__Detection3DArray_ *a = samples[i];
    printf ("det3d %u %d %u %s\n", a->detections._length, a->header.stamp.sec, a->header.stamp.nanosec, a->header.frame_id);
    for (uint32_t j = 0; j < a->detections._length; j++) {
      const vision_msgs_msg_dds__Detection3D_ *d = &a->detections._buffer[j];
      const geometry_msgs_msg_dds__Point_ *p = &d->bbox.center.position;
      const vision_msgs_msg_dds__ObjectHypothesisWithPose_ *r = d->results._length ? &d->results._buffer[0] : NULL;
      printf ("fruit %s %.9g %.9g %.9g %.9g %.9g %.9g %.9g %s %.9g\n", d->id, p->x, p->y, p->z, d->bbox.size.x, d->bbox.size.y,
              d->bbox.size.z, r ? r->pose.covariance[0] : -1.0, r && r->hypothesis.class_id[0] ? r->hypothesis.class_id : "-",
              r ? r->hypothesis.score : -1.0);
    }
  }
  if (n > 0)
    dds_return_loan (reader, samples, n);
}

int main (int argc, char **argv)
{
  if (argc != 3) {
    fprintf (stderr, "usage: peer DOMAIN PREFIX\n");
    return 2;
  }
  const char *prefix = argv[2];
  char names[5][256];
  const char *suffixes[5] = { "/camera_info", "/detections", "/tf", "/tf_static", "/fruit/detections" };
  for (int i = 0; i < 5; i++)
    snprintf (names[i], sizeof (names[i]), "rt%s%s", prefix, suffixes[i]);
  dds_entity_t pp = dds_create_participant ((dds_domainid_t) atoi (argv[1]), NULL, NULL);
  DDS_OK (pp);
  struct kind kinds[] = {
    { "camera_info", names[0], &sensor_msgs_msg_dds__CameraInfo__desc, 10, 0, 0 },
    { "detections", names[1], &vision_msgs_msg_dds__Detection2DArray__desc, 10, 0, 0 },
    { "tf", names[2], &tf2_msgs_msg_dds__TFMessage__desc, 100, 0, 0 },
    { "tf_static", names[3], &tf2_msgs_msg_dds__TFMessage__desc, 1, 1, 0 },
  };
  const size_t nkinds = sizeof (kinds) / sizeof (kinds[0]);
  for (size_t i = 0; i < nkinds; i++) {
    dds_entity_t topic = dds_create_topic (pp, kinds[i].desc, kinds[i].topic, NULL, NULL);
    DDS_OK (topic);
    dds_qos_t *qos = rmw_qos (kinds[i].history, 1, kinds[i].transient);
    kinds[i].writer = dds_create_writer (pp, topic, qos, NULL);
    DDS_OK (kinds[i].writer);
    dds_delete_qos (qos);
  }
  dds_entity_t out_topic = dds_create_topic (pp, &vision_msgs_msg_dds__Detection3DArray__desc, names[4], NULL, NULL);
  DDS_OK (out_topic);
  dds_qos_t *rqos = rmw_qos (10, 1, 0);
  dds_entity_t reader = dds_create_reader (pp, out_topic, rqos, NULL);
  DDS_OK (reader);
  dds_delete_qos (rqos);
  printf ("ready\n");
  fflush (stdout);

  static char line[1 << 22];
  int matched = 0;
  for (;;) {
    if (!matched) {
      dds_publication_matched_status_t st;
      DDS_OK (dds_get_publication_matched_status (kinds[1].writer, &st));
      if (st.current_count > 0) {
        matched = 1;
        printf ("matched\n");
      }
    }
    print_detections (reader);
    fflush (stdout);
    fd_set fds;
    FD_ZERO (&fds);
    FD_SET (0, &fds);
    struct timeval tv = { 0, 20000 };
    if (select (1, &fds, NULL, NULL, &tv) <= 0)
      continue;
    if (fgets (line, sizeof (line), stdin) == NULL || strncmp (line, "quit", 4) == 0)
      break;
    line[strcspn (line, "\n")] = 0;
    char *kind = strtok (line + 4, " "), *hex = strtok (NULL, " ");
    if (strncmp (line, "pub ", 4) != 0 || kind == NULL || hex == NULL) {
      fprintf (stderr, "peer: bad command\n");
      return 2;
    }
    size_t i = 0;
    while (i < nkinds && strcmp (kinds[i].name, kind) != 0)
      i++;
    if (i == nkinds) {
      fprintf (stderr, "peer: unknown kind %s\n", kind);
      return 2;
    }
    publish (&kinds[i], hex);
  }
  dds_sleepfor (DDS_MSECS (500)); /* let reliable data reach the node before the participant goes */
  print_detections (reader);
  fflush (stdout);
  dds_delete (pp);
  return 0;
}
