// Lists "type fingerprint" for every evermap class in the jar lcm-spy loads, so a test can
// check that Java (lcm-spy) and C++ agree on every message type.
import java.util.ArrayList;
import java.util.Collections;
import java.util.Enumeration;
import java.util.List;
import java.util.jar.JarEntry;
import java.util.jar.JarFile;

public class ListTypes {
  public static void main(String[] args) throws Exception {
    List<String> lines = new ArrayList<>();
    try (JarFile jar = new JarFile(args[0])) {
      for (Enumeration<JarEntry> e = jar.entries(); e.hasMoreElements();) {
        String name = e.nextElement().getName();
        if (!name.startsWith("evermap/") || !name.endsWith(".class") || name.contains("$")) continue;
        String cls = name.replace('/', '.').substring(0, name.length() - ".class".length());
        Class<?> c = Class.forName(cls);
        long fp = c.getField("LCM_FINGERPRINT").getLong(null);
        // lcm.lcm.LCMEncodable: the class must also be decodable by lcm-spy.
        if (!lcm.lcm.LCMEncodable.class.isAssignableFrom(c)) throw new Exception(cls + " is not LCMEncodable");
        lines.add(c.getSimpleName() + " " + fp);
      }
    }
    Collections.sort(lines);
    for (String l : lines) System.out.println(l);
  }
}
